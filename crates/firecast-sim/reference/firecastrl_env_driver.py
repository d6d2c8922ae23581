"""Drive the FireCastRL Python environment (aisystems-lab/wildfire-env, the P2 engine) for
`firecast bench sim --reference-env DIR`.

FireCast does not ship that environment: DIR is the user's checkout (the folder holding the
`firecastrl_env` package), and the interpreter must have its dependencies (gymnasium, numpy,
pillow, websockets, requests). This script only imports it and steps it.

Usage: firecastrl_env_driver.py ENV_DIR EPISODES_JSON
EPISODES_JSON: [{"seed": 1, "actions": [0, 3, 4], "max_steps": 2000}, ...]; each episode
seeds Python's `random` with `seed` (the engine's only generator), resets, and steps the
action list cyclically until terminated or truncated (or max_steps).
Prints one JSON line: per episode steps, burnt and peak burning cells, a state checksum of
the final fire-state grid (sum over row-major cells of index * state) and seconds spent in
env.step.
"""

import json
import random
import sys
import time


def main():
    env_dir, episodes_json = sys.argv[1], sys.argv[2]
    sys.path.insert(0, env_dir)
    import numpy as np
    from firecastrl_env.envs.wildfire_env import WildfireEnv

    with open(episodes_json) as f:
        episodes = json.load(f)
    t0 = time.perf_counter()
    env = WildfireEnv(render_mode=None)
    construct_seconds = time.perf_counter() - t0
    out = []
    for ep in episodes:
        random.seed(ep["seed"])
        env.reset(seed=ep["seed"])
        actions = ep["actions"]
        steps = peak = 0
        seconds = 0.0
        while True:
            a = actions[steps % len(actions)]
            t = time.perf_counter()
            _, _, terminated, truncated, info = env.step(a)
            seconds += time.perf_counter() - t
            steps += 1
            peak = max(peak, info["cells_burning"])
            if terminated or truncated or steps >= ep["max_steps"]:
                break
        fire_state = env.cell_state.fire_state.astype(np.int64).ravel()
        checksum = int((np.arange(fire_state.size, dtype=np.int64) * fire_state).sum())
        out.append(
            {
                "seed": ep["seed"],
                "steps": steps,
                "burnt": int(info["cells_burnt"]),
                "burning": int(info["cells_burning"]),
                "peak_burning": peak,
                "checksum": checksum,
                "terminated": bool(terminated),
                "seconds": seconds,
            }
        )
    print(json.dumps({"construct_seconds": construct_seconds, "episodes": out}))


if __name__ == "__main__":
    main()
