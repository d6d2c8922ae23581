"""SB3's side of `firecast bench ppo`: CartPole-v1 with the same PPO settings and one torch
thread, timed in four phases (environment only, rollout = environment + inference, updates
only = PPO's epochs over a collected rollout, training = SB3's learn including updates).
Prints one JSON object."""
import json
import sys
import time

import numpy as np
import torch

torch.set_num_threads(1)
import gymnasium as gym  # noqa: E402
from stable_baselines3 import PPO  # noqa: E402
from stable_baselines3.common.env_util import make_vec_env  # noqa: E402
from stable_baselines3.common.logger import Logger  # noqa: E402


def main():
    cfg = json.loads(sys.argv[1])
    n_envs, steps, seed = cfg["n_envs"], cfg["steps"], cfg["seed"]
    lin = lambda v: (lambda p: p * v)  # noqa: E731

    def model():
        env = make_vec_env("CartPole-v1", n_envs=n_envs, seed=seed)
        m = PPO(
            "MlpPolicy", env, n_steps=cfg["n_steps"], batch_size=cfg["batch_size"],
            n_epochs=cfg["n_epochs"], gamma=cfg["gamma"], gae_lambda=cfg["gae_lambda"],
            ent_coef=cfg["ent_coef"], learning_rate=lin(cfg["learning_rate"]),
            clip_range=lin(cfg["clip_range"]), seed=seed, device="cpu", verbose=0,
        )
        # A logger without outputs: SB3's default makes a /tmp/SB3-<time> folder per model.
        m.set_logger(Logger(folder=None, output_formats=[]))
        return m

    out = {"sb3": __import__("stable_baselines3").__version__, "torch": torch.__version__,
           "gymnasium": gym.__version__}
    # Environment only.
    venv = make_vec_env("CartPole-v1", n_envs=n_envs, seed=seed)
    venv.reset()
    rng = np.random.default_rng(seed)
    rounds = steps // n_envs
    actions = rng.integers(0, 2, size=(rounds, n_envs))
    t = time.perf_counter()
    for r in range(rounds):
        venv.step(actions[r])
    out["env_sps"] = rounds * n_envs / (time.perf_counter() - t)
    # Rollout: SB3's collect_rollouts (inference + environment + buffer), no update.
    m = model()
    out["parameters"] = sum(p.numel() for p in m.policy.parameters() if p.requires_grad)
    _, callback = m._setup_learn(steps, callback=None)
    callback.on_training_start(locals(), globals())
    n_rollouts = max(1, steps // (n_envs * cfg["n_steps"]))
    t = time.perf_counter()
    for _ in range(n_rollouts):
        m.collect_rollouts(m.env, callback, m.rollout_buffer, n_rollout_steps=m.n_steps)
    out["rollout_sps"] = n_rollouts * n_envs * cfg["n_steps"] / (time.perf_counter() - t)
    # Updates only: PPO's epochs over the last rollout, as many as training runs, without
    # the approx-KL early stop (the network's forward, backward and Adam steps).
    m.target_kl = None
    t = time.perf_counter()
    for _ in range(n_rollouts):
        m.train()
    out["update_sps"] = n_rollouts * n_envs * cfg["n_steps"] / (time.perf_counter() - t)
    # Arithmetic per step and the machine's sgemm rate (network_work.py, run ahead of this
    # script), outside the timed phases.
    out.update(network_work(m))  # noqa: F821
    # Training, as `learn` reports fps.
    m = model()
    t = time.perf_counter()
    m.learn(steps)
    out["train_sps"] = m.num_timesteps / (time.perf_counter() - t)
    print(json.dumps(out))


if __name__ == "__main__":
    main()
