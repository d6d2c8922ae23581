"""How much arithmetic PPO's network does per environment step, and how fast this machine
multiplies matrices: the yardstick `firecast bench ppo` holds its goals against. The CLI runs
this file ahead of bench_sb3.py and bench_sb3_helitack.py (`python -c`), which call
`network_work(model)` after their timed phases.

FLOPs are torch's own count (`torch.utils.flop_counter.FlopCounterMode`: convolutions and
matrix products, forward and backward; elementwise work, pooling and Adam are not counted), on
a minibatch of the model's collected rollout: per environment step one forward pass
(inference in the rollout) plus n_epochs forward + backward passes (the updates). torch's
counter does not see recurrent layers (its LSTM and GRU kernels are fused), so those are
counted here by hand from the shapes each call sees: 2 * gates * hidden * (input + hidden)
FLOPs per time step, layer, direction and batch row (gates: 4 LSTM, 3 GRU), forward; times 3
with the backward pass (its two matrix products per forward one).

The yardstick is the fastest matrix product this CPU has, timed on 2048 x 2048 matrices at the
process's torch threads: float32 (`sgemm_gflops`) and bfloat16 (`bf16_gflops`; CPUs with
AVX512-BF16 or AMX run it several times faster).
"""
import time as _time

import torch as _torch


def _recurrent_flops(module, inputs):
    """Forward FLOPs of one call of an nn.LSTM or nn.GRU on `inputs`."""
    x = inputs[0]
    if isinstance(x, _torch.nn.utils.rnn.PackedSequence):
        steps_rows = x.data.shape[0]
    else:
        steps_rows = x.shape[0] * (x.shape[1] if x.dim() == 3 else 1)
    gates = 4 if isinstance(module, _torch.nn.LSTM) else 3
    h = module.hidden_size
    dirs = 2 if module.bidirectional else 1
    total = 0
    for layer in range(module.num_layers):
        i = module.input_size if layer == 0 else h * dirs
        total += 2 * gates * h * (i + h) * dirs
    return total * steps_rows


def _count_recurrent(model):
    counted = [0]
    hooks = []
    for m in model.policy.modules():
        if isinstance(m, (_torch.nn.LSTM, _torch.nn.GRU)):
            hooks.append(m.register_forward_pre_hook(lambda mod, inp: counted.__setitem__(0, counted[0] + _recurrent_flops(mod, inp))))
    return counted, hooks


def _rate(dtype, n=2048, reps=10):
    a, b = _torch.randn(n, n).to(dtype), _torch.randn(n, n).to(dtype)
    for _ in range(3):
        a @ b
    t = _time.perf_counter()
    for _ in range(reps):
        a @ b
    return reps * 2 * n**3 / (_time.perf_counter() - t) / 1e9


def network_work(model):
    from torch.utils.flop_counter import FlopCounterMode

    data = next(model.rollout_buffer.get(model.batch_size))
    actions = data.actions
    if actions.dim() > 1 and actions.shape[1] == 1:
        actions = actions.long().flatten()
    n = actions.shape[0]
    counted, hooks = _count_recurrent(model)
    with _torch.no_grad(), FlopCounterMode(display=False) as forward:
        model.policy.evaluate_actions(data.observations, actions)
    recurrent_forward = counted[0]
    counted[0] = 0
    with FlopCounterMode(display=False) as train:
        values, log_prob, entropy = model.policy.evaluate_actions(data.observations, actions)
        (values.sum() + log_prob.sum() + entropy.sum()).backward()
    recurrent_train = 3 * counted[0]
    for hk in hooks:
        hk.remove()
    model.policy.zero_grad()
    counted_by_torch = (forward.get_total_flops() + model.n_epochs * train.get_total_flops()) / n
    recurrent = (recurrent_forward + model.n_epochs * recurrent_train) / n
    return {
        "flops_per_step": counted_by_torch + recurrent,
        "recurrent_flops_per_step": recurrent,
        "sgemm_gflops": _rate(_torch.float32),
        "bf16_gflops": _rate(_torch.bfloat16),
    }
