"""Environment-only throughput through the Python package: ``python -m firecast.bench``.

Random actions on the 240 × 160 landscape ``procedural:2`` with a 10 mi/h west wind (there the
unsuppressed fire burns about 17,000 cells over some 600 steps); prints steps per second of
``HelitackEnv`` and of ``HelitackVecEnv`` (observations copied into numpy every step).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from .env import HelitackEnv

CONFIG = {"max_steps": 2000, "sim": {"wind": {"speed_mph": 10.0, "from_direction_deg": 270.0}}}


def single(seconds: float, landscape: str) -> float:
    env = HelitackEnv(landscape=landscape, config=CONFIG)
    rng = np.random.default_rng(0)
    env.reset(seed=0)
    steps, start = 0, time.perf_counter()
    while time.perf_counter() - start < seconds:
        _, _, terminated, truncated, _ = env.step(int(rng.integers(5)))
        steps += 1
        if terminated or truncated:
            env.reset()
    return steps / (time.perf_counter() - start)


def vectorised(seconds: float, landscape: str, num_envs: int) -> float:
    from .vec_env import HelitackVecEnv

    vec = HelitackVecEnv(num_envs, seed=0, landscape=landscape, config=CONFIG)
    rng = np.random.default_rng(0)
    vec.reset()
    steps, start = 0, time.perf_counter()
    while time.perf_counter() - start < seconds:
        vec.step(rng.integers(0, 5, size=num_envs))
        steps += num_envs
    return steps / (time.perf_counter() - start)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seconds", type=float, default=10.0, help="per measurement")
    parser.add_argument("--landscape", default="procedural:2")
    parser.add_argument("--num-envs", type=int, default=8)
    args = parser.parse_args()
    print(f"HelitackEnv:        {single(args.seconds, args.landscape):10.0f} steps/s")
    rate = vectorised(args.seconds, args.landscape, args.num_envs)
    print(f"HelitackVecEnv({args.num_envs}): {rate:10.0f} steps/s (all environments)")


if __name__ == "__main__":
    main()
