"""Stable-Baselines3's PPO learning on FireCast's helitack environment, as a reference for what
`firecast rl train` learns: the compact policy re-stated for SB3 (bench_sb3_helitack.py), the
paper's hyper-parameters (training_improved.py) with `--ent-coef` overridable, reward
normalisation only, `firecast.HelitackVecEnv` with 8 environments over the training
landscapes of experiments/rl/fires/small-map.yaml (procedural seeds 1-8 on 96 x 64,
400-step episodes, P2 reward). The Python package takes one weather for every fire, so the
fires differ from the fire file's: 8 fixed ignition cells, a 1.5 mi/h wind from 45 degrees
and the default fuel moisture. Prints SB3's own logger output (rollout/ep_rew_mean,
train/entropy_loss, ...) every update.

    .venv/bin/python crates/firecast-rl/reference/learn_sb3_helitack.py --steps 60000 --ent-coef 0.01
"""
import argparse
import os
import sys

import torch

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from bench_sb3_helitack import CompactExtractor  # noqa: E402
from firecast import HelitackVecEnv  # noqa: E402
from stable_baselines3 import PPO  # noqa: E402
from stable_baselines3.common.vec_env import VecNormalize  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--steps", type=int, default=60_000)
    ap.add_argument("--ent-coef", type=float, default=0.2, help="the paper's is 0.2")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--threads", type=int, default=2)
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    landscapes = [{"procedural": {"seed": s, "width": 96, "height": 64}} for s in range(1, 9)]
    ignitions = [(30, 30), (48, 32), (60, 40), (40, 24), (70, 30), (50, 45), (36, 40), (60, 22)]
    env = HelitackVecEnv(
        8,
        seed=args.seed,
        landscapes=landscapes,
        ignitions=ignitions,
        config={"max_steps": 400, "sim": {"wind": {"speed_mph": 1.5, "from_direction_deg": 45}}},
    )
    venv = VecNormalize(env, norm_obs=False, norm_reward=True, gamma=0.95)
    policy_kwargs = dict(
        features_extractor_class=CompactExtractor,
        net_arch=dict(pi=[64, 64], vf=[64, 64]),
        activation_fn=torch.nn.Tanh,
        ortho_init=True,
        optimizer_kwargs=dict(eps=1e-5),
    )
    model = PPO(
        "MultiInputPolicy",
        venv,
        n_steps=128,
        batch_size=64,
        n_epochs=3,
        learning_rate=3e-4,
        clip_range=0.1,
        gamma=0.95,
        gae_lambda=0.9,
        ent_coef=args.ent_coef,
        vf_coef=0.4,
        max_grad_norm=1.0,
        target_kl=0.03,
        policy_kwargs=policy_kwargs,
        seed=args.seed,
        device="cpu",
        verbose=1,
    )
    model.learn(args.steps)


if __name__ == "__main__":
    main()
