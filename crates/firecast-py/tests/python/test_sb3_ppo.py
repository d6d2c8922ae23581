"""Stable-Baselines3's PPO trains on HelitackVecEnv (a small grid, a few thousand steps)."""

from __future__ import annotations

import time
import warnings

import numpy as np
import torch
from conftest import small
from stable_baselines3 import PPO
from stable_baselines3.common.evaluation import evaluate_policy
from stable_baselines3.common.logger import Logger

from firecast import HelitackVecEnv


def test_ppo_multi_input_policy_trains_on_the_vec_env():
    torch.set_num_threads(1)
    vec = HelitackVecEnv(4, seed=0, **small(max_steps=100))
    start = time.perf_counter()
    model = PPO(
        "MultiInputPolicy",
        vec,
        n_steps=64,
        batch_size=64,
        n_epochs=2,
        seed=0,
        device="cpu",
        verbose=0,
    )
    # A logger without outputs: SB3's default makes a /tmp/SB3-<time> folder per model.
    model.set_logger(Logger(folder=None, output_formats=[]))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model.learn(total_timesteps=2048)
    elapsed = time.perf_counter() - start
    assert [str(w.message) for w in caught if "firecast" in (w.filename or "")] == []
    assert model.num_timesteps >= 2048
    # Episodes (100 steps) ended during training and SB3 read their `episode` infos.
    assert len(model.ep_info_buffer) >= 8
    assert all(info["l"] == 100 for info in model.ep_info_buffer)
    assert np.isfinite(model.logger.name_to_value.get("train/value_loss", 0.0))
    assert elapsed < 60, f"training took {elapsed:.1f} s"

    # evaluate_policy accepts it as Monitor-wrapped (no warning) and sees whole episodes.
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        mean, std = evaluate_policy(model, vec, n_eval_episodes=4, deterministic=True)
    assert [str(w.message) for w in caught] == []
    assert np.isfinite(mean) and np.isfinite(std)
    actions, _ = model.predict(vec.reset(), deterministic=True)
    assert actions.shape == (4,) and set(actions.tolist()) <= set(range(5))
