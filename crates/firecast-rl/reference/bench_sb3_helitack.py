"""SB3's side of `firecast bench ppo` parts (b) and (c): Stable-Baselines3's PPO with FireCast's
compact policy re-stated as an SB3 features extractor (crates/firecast-rl/src/policy.rs,
`Extractor::Compact`), the same hyper-parameters and the same torch threads, timed in four
phases (environment only, rollout = environment + inference, updates only = PPO's epochs over
a collected rollout, training = SB3's learn including updates). Prints one JSON object with the speeds and the parameter count.

(b) `env.kind = "firecast"`: FireCast's helitack environment through the Python package
    (`firecast.HelitackVecEnv`, the Rust VecEnv stepping on all cores).
(c) `env.kind = "firecastrl"`: the FireCastRL Python environment (a checkout of
    aisystems-lab/wildfire-env), one per worker process (SubprocVecEnv when more than one
    thread is given, so its steps use the cores as FireCast's do), its state re-encoded
    into FireCast's observation (4 stacked frames of cell codes, the helicopter cell, the
    on-fire flag) so that both sides run the same network.

Usage: bench_sb3_helitack.py CONFIG_JSON
"""
import json
import sys
import time

import numpy as np
import torch

import gymnasium as gym  # noqa: E402
import torch.nn.functional as F  # noqa: E402
from gymnasium import spaces  # noqa: E402
from stable_baselines3 import PPO  # noqa: E402
from stable_baselines3.common.logger import Logger  # noqa: E402
from stable_baselines3.common.monitor import Monitor  # noqa: E402
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor  # noqa: E402
from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv, VecNormalize  # noqa: E402
from torch import nn  # noqa: E402

FRAME_STACK = 4
CODE_MAX = 9.0
COMPACT_FEATURES = 256


class CompactExtractor(BaseFeaturesExtractor):
    """FireCast's `compact` extractor: the image is the 4-frame stack plus a helicopter channel
    (CODE_MAX on the helicopter's cell) divided by CODE_MAX and average-pooled 2x; branches
    a (3x3 conv, max pool, twice), b (5x5 stride-2 convs) and c (11x11 stride 4, 7x7 stride 2,
    bilinear upsampling), spatial attention (f * sigmoid(att) + f), a 1x1 reduction to 16
    channels average-pooled to at most 10 x 15, fused with Linear(3 -> 64) of [x, y, on_fire]
    into 256 features. ReLU throughout, no batch normalisation (FireCast's default)."""

    def __init__(self, observation_space: spaces.Dict):
        super().__init__(observation_space, features_dim=COMPACT_FEATURES)
        c, h, w = observation_space["cells"].shape
        c_in = c + 1
        a1, a2, b1, b2, c1, c2 = 16, 32, 8, 16, 8, 16
        self.a0, self.a1 = nn.Conv2d(c_in, a1, 3, 1, 1), nn.Conv2d(a1, a2, 3, 1, 1)
        self.b0, self.b1 = nn.Conv2d(c_in, b1, 5, 2, 2), nn.Conv2d(b1, b2, 5, 2, 2)
        self.c0, self.c1 = nn.Conv2d(c_in, c1, 11, 4, 5), nn.Conv2d(c1, c2, 7, 2, 3)
        total = a2 + b2 + c2
        self.att1, self.att2 = nn.Conv2d(total, 32, 1), nn.Conv2d(32, 1, 1)
        self.size = ((h // 2) // 4, (w // 2) // 4)
        self.pooled = (min(self.size[0], 10), min(self.size[1], 15))
        self.reduce = nn.Conv2d(total, 16, 1)
        self.vector_net = nn.Linear(3, 64)
        self.fuse = nn.Linear(16 * self.pooled[0] * self.pooled[1] + 64, COMPACT_FEATURES)

    def forward(self, obs):
        cells = obs["cells"]
        n, _, h, w = cells.shape
        xy = obs["helicopter_coord"]
        x = xy[:, 0].long().clamp(0, w - 1)
        y = xy[:, 1].long().clamp(0, h - 1)
        heli = torch.zeros(n, h * w, dtype=cells.dtype, device=cells.device)
        heli.scatter_(1, (y * w + x)[:, None], CODE_MAX)
        img = torch.cat([cells, heli.view(n, 1, h, w)], 1) / CODE_MAX
        img = F.avg_pool2d(img, 2)
        a = F.max_pool2d(F.relu(self.a0(img)), 2)
        a = F.max_pool2d(F.relu(self.a1(a)), 2)
        b = F.relu(self.b1(F.relu(self.b0(img))))
        c = F.relu(self.c1(F.relu(self.c0(img))))
        c = F.interpolate(c, size=self.size, mode="bilinear", align_corners=False)
        f = torch.cat([a, b, c], 1)
        f = f * torch.sigmoid(self.att2(F.relu(self.att1(f)))) + f
        f = F.adaptive_avg_pool2d(F.relu(self.reduce(f)), self.pooled).flatten(1)
        # SB3 one-hot encodes Discrete(2) ((n, 2) from the env, (n, 1, 2) from the buffer):
        # column 1 is the flag.
        on_fire = obs["on_fire"].reshape(n, 2)[:, 1:2]
        v = F.relu(self.vector_net(torch.cat([xy, on_fire], 1)))
        return F.relu(self.fuse(torch.cat([f, v], 1)))


class FireCastObservation(gym.Wrapper):
    """The FireCastRL environment seen through FireCast's observation: per step a frame of
    cell codes (0 non-burnable, else fire state * 3 + 1: FireCastRL keeps no burn-index
    grid, so the index is Low), the last 4 frames oldest first, the helicopter cell and
    whether it is burning."""

    def __init__(self, env):
        super().__init__(env)
        base = env.unwrapped
        h, w = base.gridHeight, base.gridWidth
        self.observation_space = spaces.Dict(
            {
                "cells": spaces.Box(0, int(CODE_MAX), (FRAME_STACK, h, w), np.uint8),
                "helicopter_coord": spaces.Box(
                    np.zeros(2, np.int32), np.array([w - 1, h - 1], np.int32), dtype=np.int32
                ),
                "on_fire": spaces.Discrete(2),
            }
        )
        self._frames = np.zeros((FRAME_STACK, h, w), np.uint8)

    def _frame(self):
        cs = self.env.unwrapped.cell_state
        code = cs.fire_state.astype(np.uint8) * 3 + 1
        code[cs.is_nonburnable] = 0
        return code

    def _obs(self, raw):
        x, y = (int(v) for v in raw["helicopter_coord"])
        burning = int(self.env.unwrapped.cell_state.fire_state[y, x] == 1)
        return {"cells": self._frames.copy(), "helicopter_coord": raw["helicopter_coord"], "on_fire": burning}

    def reset(self, **kwargs):
        raw, info = self.env.reset(**kwargs)
        self._frames[:] = self._frame()
        return self._obs(raw), info

    def step(self, action):
        raw, reward, terminated, truncated, info = self.env.step(int(action))
        self._frames[:-1] = self._frames[1:]
        self._frames[-1] = self._frame()
        return self._obs(raw), reward, terminated, truncated, info


def firecastrl_env(env_dir):
    def make():
        sys.path.insert(0, env_dir)
        from firecastrl_env.envs.wildfire_env import WildfireEnv

        return Monitor(FireCastObservation(WildfireEnv(render_mode=None)))

    return make


def schedule(value):
    """FireCast's `Schedule`: a constant or {linear, end} over the remaining progress."""
    if isinstance(value, dict):
        start, end = float(value["linear"]), float(value.get("end", 0.0))
        return lambda p: end + (start - end) * p
    return float(value)


def reward_normalizer(venv, norm, gamma):
    """SB3's `VecNormalize` as FireCast's `normalize` settings describe it (rewards only; its
    `gamma` falls back to PPO's)."""
    return VecNormalize(
        venv,
        norm_obs=False,
        norm_reward=norm["reward"],
        clip_obs=norm["clip_obs"],
        clip_reward=norm["clip_reward"],
        gamma=norm["gamma"] if norm["gamma"] is not None else gamma,
        epsilon=norm["epsilon"],
    )


def sb3_ppo_kwargs(ppo, policy, extractor, script):
    """FireCast's PPO settings (without `n_envs`, `total_timesteps`, `normalize`) and compact
    policy as SB3's `PPO(...)` keyword arguments and `policy_kwargs`; a setting SB3 is not
    given stops the script."""
    ppo = dict(ppo)
    kwargs = dict(
        n_steps=ppo.pop("n_steps"),
        batch_size=ppo.pop("batch_size"),
        n_epochs=ppo.pop("n_epochs"),
        learning_rate=schedule(ppo.pop("learning_rate")),
        clip_range=schedule(ppo.pop("clip_range")),
        clip_range_vf=ppo.pop("clip_range_vf"),
        gamma=ppo.pop("gamma"),
        gae_lambda=ppo.pop("gae_lambda"),
        ent_coef=ppo.pop("ent_coef"),
        vf_coef=ppo.pop("vf_coef"),
        max_grad_norm=ppo.pop("max_grad_norm"),
        target_kl=ppo.pop("target_kl"),
        normalize_advantage=ppo.pop("normalize_advantage"),
    )
    eps = ppo.pop("adam_eps")
    if ppo:
        sys.exit(f"{script}: PPO settings this script does not pass to SB3: {sorted(ppo)}")
    policy_kwargs = dict(
        features_extractor_class=extractor,
        net_arch=dict(pi=list(policy["pi"]), vf=list(policy["vf"])),
        activation_fn={"tanh": nn.Tanh, "relu": nn.ReLU}[policy["activation"]],
        ortho_init=policy["ortho_init"],
        optimizer_kwargs=dict(eps=eps),
    )
    return kwargs, policy_kwargs


def main():
    cfg = json.loads(sys.argv[1])
    threads = int(cfg["threads"])
    torch.set_num_threads(threads)
    steps, seed = int(cfg["steps"]), int(cfg["seed"])
    n_envs = int(cfg["ppo"]["n_envs"])
    norm = cfg["ppo"]["normalize"]
    if norm["obs"]:
        sys.exit("bench_sb3_helitack.py: observation normalisation is not part of this benchmark")
    env = cfg["env"]
    policy = cfg["policy"]
    if policy["kind"] != "compact" or policy["batch_norm"]:
        sys.exit(f"bench_sb3_helitack.py: only the compact policy without batch norm is re-stated here, not {policy}")

    def venv():
        if env["kind"] == "firecast":
            from firecast import HelitackVecEnv

            return HelitackVecEnv(n_envs, seed=seed, **env["kwargs"])
        fns = [firecastrl_env(env["dir"])] * n_envs
        if threads > 1:
            return SubprocVecEnv(fns)
        return DummyVecEnv(fns)

    def model():
        ppo = dict(cfg["ppo"])
        for k in ("n_envs", "total_timesteps", "normalize"):
            ppo.pop(k)
        v = reward_normalizer(venv(), norm, ppo["gamma"])
        kwargs, policy_kwargs = sb3_ppo_kwargs(ppo, policy, CompactExtractor, "bench_sb3_helitack.py")
        m = PPO("MultiInputPolicy", v, policy_kwargs=policy_kwargs, seed=seed, device="cpu", verbose=0, **kwargs)
        # A logger without outputs: SB3's default makes a /tmp/SB3-<time> folder per model.
        m.set_logger(Logger(folder=None, output_formats=[]))
        return m

    import stable_baselines3

    out = {
        "sb3": stable_baselines3.__version__,
        "torch": torch.__version__,
        "gymnasium": gym.__version__,
        "threads": torch.get_num_threads(),
        "vec_env": None,
    }
    # Environment only: the VecEnv PPO steps (without VecNormalize), random actions.
    v = venv()
    out["vec_env"] = type(v).__name__
    v.seed(seed)
    v.reset()
    rng = np.random.default_rng(seed)
    rounds = max(1, steps // n_envs)
    actions = rng.integers(0, 5, size=(rounds, n_envs))
    t = time.perf_counter()
    for r in range(rounds):
        v.step(actions[r])
    out["env_sps"] = rounds * n_envs / (time.perf_counter() - t)
    v.close()
    # Rollout: SB3's collect_rollouts (inference + environment + buffer), no update.
    m = model()
    out["parameters"] = sum(p.numel() for p in m.policy.parameters() if p.requires_grad)
    _, callback = m._setup_learn(steps, callback=None)
    callback.on_training_start(locals(), globals())
    n_rollouts = max(1, steps // (n_envs * m.n_steps))
    t = time.perf_counter()
    for _ in range(n_rollouts):
        m.collect_rollouts(m.env, callback, m.rollout_buffer, n_rollout_steps=m.n_steps)
    out["rollout_sps"] = n_rollouts * n_envs * m.n_steps / (time.perf_counter() - t)
    m.env.close()
    # Updates only: PPO's epochs over the last rollout, as many as training runs, without
    # the approx-KL early stop (the network's forward, backward and Adam steps).
    m.target_kl = None
    t = time.perf_counter()
    for _ in range(n_rollouts):
        m.train()
    out["update_sps"] = n_rollouts * n_envs * m.n_steps / (time.perf_counter() - t)
    # Arithmetic per step and the machine's sgemm rate (network_work.py, run ahead of this
    # script), outside the timed phases.
    out.update(network_work(m))  # noqa: F821
    # Training, as `learn` reports fps.
    m = model()
    t = time.perf_counter()
    m.learn(steps)
    out["train_sps"] = m.num_timesteps / (time.perf_counter() - t)
    m.env.close()
    print(json.dumps(out))


if __name__ == "__main__":
    main()
