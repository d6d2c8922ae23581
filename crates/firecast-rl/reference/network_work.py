"""How much arithmetic PPO's network does per environment step, and how fast this machine
multiplies matrices: the yardstick `firecast bench ppo` holds its goals against. The CLI runs
this file ahead of bench_sb3.py and bench_sb3_helitack.py (`python -c`), which call
`network_work(model)` after their timed phases.

FLOPs are torch's own count (`torch.utils.flop_counter.FlopCounterMode`: convolutions and
matrix products, forward and backward; elementwise work, pooling and Adam are not counted), on
a minibatch of the model's collected rollout: per environment step one forward pass
(inference in the rollout) plus n_epochs forward + backward passes (the updates). The sgemm
rate is a 2048 x 2048 float32 matrix product at the process's torch threads.
"""
import time as _time

import torch as _torch


def network_work(model):
    from torch.utils.flop_counter import FlopCounterMode

    data = next(model.rollout_buffer.get(model.batch_size))
    actions = data.actions
    if actions.dim() > 1 and actions.shape[1] == 1:
        actions = actions.long().flatten()
    n = actions.shape[0]
    with _torch.no_grad(), FlopCounterMode(display=False) as forward:
        model.policy.evaluate_actions(data.observations, actions)
    with FlopCounterMode(display=False) as train:
        values, log_prob, entropy = model.policy.evaluate_actions(data.observations, actions)
        (values.sum() + log_prob.sum() + entropy.sum()).backward()
    model.policy.zero_grad()
    per_step = (forward.get_total_flops() + model.n_epochs * train.get_total_flops()) / n

    a, b = _torch.randn(2048, 2048), _torch.randn(2048, 2048)
    for _ in range(3):
        a @ b
    reps = 10
    t = _time.perf_counter()
    for _ in range(reps):
        a @ b
    sgemm = reps * 2 * 2048**3 / (_time.perf_counter() - t)
    return {"flops_per_step": per_step, "sgemm_gflops": sgemm / 1e9}
