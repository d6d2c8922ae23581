"""SB3's side of `firecast bench quality`: Stable-Baselines3's PPO trained from nothing with the
given hyper-parameters (the paper's) and FireCast's compact network (`firecast.CompactExtractor`,
whose parameters carry the Rust policy's names), a checkpoint of the policy's weights stamped
every `every` seconds of training wall-clock until `seconds` have passed or `steps` are done
(the paper's 300,000). Saving is not counted in the clock; SB3 checks the clock once per rollout
(in `_on_rollout_start`, after the previous update), so a stamp lands at the first rollout
boundary past its mark and carries the seconds and steps of that moment.

Environments (`env.kind`):
- `firecast`: `firecast.HelitackVecEnv` (the control row: FireCast's environment, SB3's trainer);
- `firecastrl`: the FireCastRL Python environment of a checkout of aisystems-lab/wildfire-env,
  seen through FireCast's observation (`FireCastObservation` of bench_sb3_helitack.py, which
  sits beside this script), `SubprocVecEnv` over the threads (the reference row: the paper's
  setup).

Each checkpoint is `<out>/checkpoint-<k>.safetensors` (the safetensors layout written with
numpy: an 8-byte little-endian header length, a JSON header, the float32 data), holding the
policy's state_dict without SB3's `pi_`/`vf_features_extractor` aliases of the shared
extractor. The last line printed is one JSON object: the checkpoints (file, seconds, steps), the
parameter count, and a parity probe: the log-probabilities and value the last checkpoint gives
one fixed observation, which the Rust side recomputes after loading the weights.

Usage: quality_sb3.py CONFIG_JSON (run by `firecast bench quality`, with bench_sb3_helitack.py
in the same folder and that folder on PYTHONPATH for the worker processes)
"""
import json
import os
import sys
import time

import numpy as np
import torch


def write_safetensors(path, tensors):
    """`tensors`: name -> float32 torch tensor. Written to a temporary sibling, then renamed."""
    header, blobs, offset = {}, [], 0
    for name in sorted(tensors):
        a = np.ascontiguousarray(tensors[name].detach().cpu().numpy().astype("<f4"))
        b = a.tobytes()
        header[name] = {"dtype": "F32", "shape": list(a.shape), "data_offsets": [offset, offset + len(b)]}
        blobs.append(b)
        offset += len(b)
    head = json.dumps(header, separators=(",", ":")).encode()
    head += b" " * (-len(head) % 8)
    tmp = path + ".partial"
    with open(tmp, "wb") as f:
        f.write(len(head).to_bytes(8, "little"))
        f.write(head)
        for b in blobs:
            f.write(b)
    os.replace(tmp, path)


def policy_weights(policy):
    return {
        k: v
        for k, v in policy.state_dict().items()
        if not k.startswith(("pi_features_extractor.", "vf_features_extractor."))
    }


def probe_observation(width, height):
    """The fixed observation of the parity probe (the Rust side builds the same one)."""
    f, y, x = np.meshgrid(np.arange(4), np.arange(height), np.arange(width), indexing="ij")
    cells = ((7 * x + 3 * y + f) % 10).astype(np.uint8)
    coord = np.array([width // 3, height // 2], dtype=np.int32)
    return {"cells": cells[None], "helicopter_coord": coord[None], "on_fire": np.array([1])}


def quality_main():
    from stable_baselines3 import PPO
    from stable_baselines3.common.callbacks import BaseCallback
    from stable_baselines3.common.logger import Logger
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv

    from bench_sb3_helitack import firecastrl_env, reward_normalizer, sb3_ppo_kwargs
    from firecast import CompactExtractor

    cfg = json.loads(sys.argv[1])
    threads, seed = int(cfg["threads"]), int(cfg["seed"])
    torch.set_num_threads(threads)
    out = cfg["out"]
    os.makedirs(out, exist_ok=True)
    ppo = dict(cfg["ppo"])
    n_envs, norm = int(ppo.pop("n_envs")), ppo.pop("normalize")
    ppo.pop("total_timesteps")
    if norm["obs"]:
        sys.exit("quality_sb3.py: observation normalisation is not part of this benchmark")
    policy = cfg["policy"]
    if policy["kind"] != "compact" or policy["batch_norm"] or policy.get("view", "map") != "map":
        sys.exit(f"quality_sb3.py: only the compact policy seeing the map is re-stated for SB3, not {policy}")
    env = cfg["env"]
    started = time.perf_counter()

    if env["kind"] == "firecast":
        from firecast import HelitackVecEnv

        venv = HelitackVecEnv(n_envs, seed=seed, **env["kwargs"])
        vec_env = "firecast.HelitackVecEnv"
    else:
        fns = [firecastrl_env(env["dir"])] * n_envs
        venv = SubprocVecEnv(fns) if threads > 1 else DummyVecEnv(fns)
        vec_env = type(venv).__name__
    venv = reward_normalizer(venv, norm, ppo["gamma"])
    kwargs, policy_kwargs = sb3_ppo_kwargs(ppo, policy, CompactExtractor, "quality_sb3.py")
    model = PPO("MultiInputPolicy", venv, policy_kwargs=policy_kwargs, seed=seed, device="cpu", verbose=0, **kwargs)
    model.set_logger(Logger(folder=None, output_formats=[]))
    every, budget = float(cfg["every"]), float(cfg["seconds"])
    checkpoints = []
    paused = [0.0]

    def clock():
        return time.perf_counter() - started - paused[0]

    def stamp():
        t0 = time.perf_counter()
        path = os.path.join(out, f"checkpoint-{len(checkpoints):03}.safetensors")
        write_safetensors(path, policy_weights(model.policy))
        checkpoints.append({"file": os.path.basename(path), "seconds": clock(), "timesteps": int(model.num_timesteps)})
        paused[0] += time.perf_counter() - t0
        print(f"checkpoint {len(checkpoints)} at {checkpoints[-1]['seconds']:.1f} s, {model.num_timesteps} steps", file=sys.stderr, flush=True)

    class Clock(BaseCallback):
        def __init__(self):
            super().__init__()
            self.stop = False

        def _on_rollout_start(self):
            t = clock()
            self.stop = t >= budget
            if self.stop or t >= every * (len(checkpoints) + 1):
                stamp()

        def _on_step(self):
            return not self.stop

    timer = Clock()
    model.learn(int(cfg["steps"]), callback=timer)
    # Stopped by the budget: stamped at that rollout's start. Otherwise the last update's policy.
    if not timer.stop:
        stamp()
    trained = clock()
    venv.close()
    probe = probe_observation(int(cfg["width"]), int(cfg["height"]))
    with torch.no_grad():
        obs, _ = model.policy.obs_to_tensor(probe)
        dist = model.policy.get_distribution(obs)
        value = model.policy.predict_values(obs)
    import stable_baselines3

    print(
        json.dumps(
            {
                "checkpoints": checkpoints,
                "trained_seconds": trained,
                "timesteps": int(model.num_timesteps),
                "parameters": sum(p.numel() for p in model.policy.parameters() if p.requires_grad),
                "vec_env": vec_env,
                "versions": f"SB3 {stable_baselines3.__version__} / torch {torch.__version__}",
                "probe": {
                    "log_probs": dist.distribution.logits[0].tolist(),
                    "value": float(value[0, 0]),
                },
            }
        )
    )


if __name__ == "__main__":
    quality_main()
