#!/usr/bin/env python3
"""Ray's per-task overhead and a sharded fire evaluation, locally and on a Ray cluster, with the
projection of a 10,000-fire evaluation onto N nodes.

    scripts/bench_ray.py --ray-address http://127.0.0.1:8265 [--ray-cpus 2] [--stages 8]
        [--episodes 400] [--shards 1 2] [--repeat 2] [--json out.json]

Without `--ray-address` only the local numbers are measured. A cluster on this machine:
    .venv/bin/ray start --head --node-ip-address=127.0.0.1 --dashboard-host=127.0.0.1 \\
        --num-cpus=2 --disable-usage-stats
(stop it with `.venv/bin/ray stop`). It works in a scratch project (`--work`, default
`.firecast/bench/ray/`) with a folder store there, so the repository's lockfiles and registry
are not touched; the release `firecast` is `$FIRECAST_BIN`, else
`$CARGO_TARGET_DIR/release/firecast`, else `target/release/firecast`.

What it measures, each run forced (`--force`) and repeated (`--repeat`, medians):
- overhead: `--stages` independent no-op `cmd` stages (`true`). Locally that is the runner's own
  cost per stage; on Ray each stage is a job, so (wall time) / (stages / CPUs) is Ray's cost per
  wave of tasks: submitting, scheduling, starting `firecast` on a worker, the store round trip
  and polling.
- evaluation: one `sim.episodes` stage (rule-based agent, the fires of
  experiments/scenarios/helitack-moderate.yaml on its 240 x 160 landscape) with `--episodes` fires, whole and in `--shards`; every run must write the same
  `summary.json` bytes. The worker's time per task comes from the task's `result.json`.

The projection of a 10,000-fire evaluation (see `project`): the per-fire CPU time of the local
whole run, spread over N nodes x `--cores` shards, plus one wave of Ray overhead and the
driver's merge, whose per-fire cost is the sharded local run's wall time less its shards'
work (taken from the per-shard worker times measured on Ray).
"""

import argparse
import glob
import hashlib
import json
import math
import os
import statistics
import subprocess
import sys
import time

from bench_windows_shards import firecast_bin

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

NOOP = """  noop{i}:
    uses: cmd
    params: {{command: "true > ${{outputs.o}}"}}
    outputs: {{o: out/noop{i}.txt}}
"""

EPISODES = """stages:
  fires:
    uses: sim.episodes
{shards}    params:
      landscape: {{procedural: {{seed: 1}}}}
      agent: rule
      episodes: {episodes}
      seed: 0
      # experiments/scenarios/helitack-moderate.yaml: fires of a few thousand cells.
      env:
        max_steps: 2000
        sim:
          kernel:
            rothermel:
              moisture: {{dead_1h_frac: 0.10, dead_10h_frac: 0.06, dead_100h_frac: 0.08, live_herb_frac: 0.6, live_woody_frac: 0.9}}
          wind: {{speed_mph: 3, from_direction_deg: 225}}
    outputs:
      summary: out/fires.json
"""


def run(work, pipeline, ray_address):
    cmd = [firecast_bin(), "--json", "--no-progress", "--store", os.path.join(work, "store"),
           "pipeline", "run", pipeline, "--force"]
    cmd += ["--executor", "ray", "--ray-address", ray_address] if ray_address else ["--executor", "local"]
    t0 = time.monotonic()
    out = subprocess.run(cmd, cwd=work, capture_output=True, text=True)
    wall = time.monotonic() - t0
    if out.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed:\n{out.stdout}\n{out.stderr}")
    report = json.loads(out.stdout)
    worker = []
    for stage in report["stages"]:
        for path in sorted(glob.glob(os.path.join(work, "store/remote", stage["run_id"], "**/result.json"),
                                     recursive=True)):
            worker.append(json.load(open(path))["seconds"])
    return {"command_s": wall, "stages": report["stages"], "worker_s": worker}


def overhead(work, n, ray_address, repeat):
    path = "pipelines/overhead.yaml"
    with open(os.path.join(work, path), "w") as f:
        f.write("stages:\n" + "".join(NOOP.format(i=i) for i in range(n)))
    # The command's wall time: the local run's is the driver's own cost (start-up, planning,
    # hashing, lockfile), which the Ray run pays too.
    return statistics.median(run(work, path, ray_address)["command_s"] for _ in range(repeat))


def episodes(work, n, shards, ray_address, repeat):
    path = f"pipelines/fires-{shards}.yaml"
    with open(os.path.join(work, path), "w") as f:
        f.write(EPISODES.format(episodes=n, shards=f"    shards: {shards}\n" if shards > 1 else ""))
    rows = []
    for _ in range(repeat):
        r = run(work, path, ray_address)
        digest = hashlib.blake2b(open(os.path.join(work, "out/fires.json"), "rb").read()).hexdigest()
        rows.append({"stage_s": r["stages"][0]["duration_secs"], "worker_s": r["worker_s"], "digest": digest})
    return {
        "executor": "ray" if ray_address else "local",
        "shards": shards,
        "stage_s": statistics.median(r["stage_s"] for r in rows),
        "worker_s": [statistics.median(v) for v in zip(*[r["worker_s"] for r in rows])],
        "digests": sorted({r["digest"] for r in rows}),
    }


def project(per_fire_s, merge_per_fire_s, overhead_per_wave_s, nodes, cores=16, fires=10_000):
    """`fires` fires in one shard per core on `nodes` nodes: the fires' CPU time spread over the
    shards, one wave of Ray overhead (every shard starts at once), and the driver's merge."""
    shards = nodes * cores
    compute = fires * per_fire_s / shards
    merge = fires * merge_per_fire_s
    return {"nodes": nodes, "cores": cores, "shards": shards, "compute_s": compute,
            "overhead_s": overhead_per_wave_s, "merge_s": merge,
            "total_s": compute + overhead_per_wave_s + merge,
            "one_core_s": fires * per_fire_s}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--ray-address")
    ap.add_argument("--ray-cpus", type=int, default=2, help="CPUs of the Ray cluster (for waves)")
    ap.add_argument("--stages", type=int, default=8, help="no-op stages for the overhead")
    ap.add_argument("--episodes", type=int, default=400)
    ap.add_argument("--shards", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--cores", type=int, default=16, help="cores per node in the projection")
    ap.add_argument("--work", default=os.path.join(ROOT, ".firecast/bench/ray"))
    ap.add_argument("--json", help="write every number here")
    args = ap.parse_args()
    os.makedirs(os.path.join(args.work, "pipelines"), exist_ok=True)
    executors = [None] + ([args.ray_address] if args.ray_address else [])

    result = {"overhead": {}, "episodes": []}
    print(f"overhead: {args.stages} no-op cmd stages")
    for ex in executors:
        name = "ray" if ex else "local"
        wall = overhead(args.work, args.stages, ex, args.repeat)
        waves = math.ceil(args.stages / args.ray_cpus) if ex else args.stages
        result["overhead"][name] = {"wall_s": wall, "per_stage_s": wall / args.stages, "waves": waves}
    local_wall = result["overhead"]["local"]["wall_s"]
    if args.ray_address:
        ray = result["overhead"]["ray"]
        # The local run's wall time is the driver's own cost (start-up, planning, lockfile).
        ray["overhead_per_wave_s"] = (ray["wall_s"] - local_wall) / ray["waves"]
    print("| executor | wall | per stage | Ray overhead per wave |\n|---|---|---|---|")
    for name, o in result["overhead"].items():
        per_wave = f"{o['overhead_per_wave_s']:.2f} s" if "overhead_per_wave_s" in o else "-"
        print(f"| {name} | {o['wall_s']:.2f} s | {o['per_stage_s']:.3f} s | {per_wave} |")

    print(f"\nevaluation: {args.episodes} fires (sim.episodes, rule agent)")
    print("| executor | shards | stage | worker per task | summary.json |\n|---|---|---|---|---|")
    digests = set()
    for ex in executors:
        for shards in args.shards:
            row = episodes(args.work, args.episodes, shards, ex, args.repeat)
            result["episodes"].append(row)
            digests.update(row["digests"])
            workers = ", ".join(f"{w:.2f}" for w in row["worker_s"]) or "-"
            print(f"| {row['executor']} | {shards} | {row['stage_s']:.2f} s | {workers} | {row['digests'][0][:12]} |")
    if len(digests) != 1:
        sys.exit(f"OUT OF BOUNDS: the runs wrote {len(digests)} different summaries")
    print("every run wrote the same summary.json")

    whole = next(r for r in result["episodes"] if r["executor"] == "local" and r["shards"] == 1)
    per_fire = whole["stage_s"] / args.episodes
    result["per_fire_s"] = per_fire
    if args.ray_address:
        sharded = [r for r in result["episodes"] if r["executor"] == "ray" and r["shards"] > 1]
        if sharded:
            s = max(sharded, key=lambda r: r["shards"])
            busy = max(max(s["worker_s"]), sum(s["worker_s"]) / args.ray_cpus)
            waves = math.ceil(s["shards"] / args.ray_cpus)
            merge = max(0.0, s["stage_s"] - busy - waves * result["overhead"]["ray"]["overhead_per_wave_s"])
            merge_per_fire = merge / args.episodes
            result["merge_per_fire_s"] = merge_per_fire
            result["projection"] = [
                project(per_fire, merge_per_fire, result["overhead"]["ray"]["overhead_per_wave_s"], n, args.cores)
                for n in (1, 2, 4, 8, 16)]
            print(f"\nprojection of a 10,000-fire evaluation: {per_fire * 1e3:.2f} ms per fire (local whole run), "
                  f"merge {merge_per_fire * 1e6:.1f} us per fire, Ray overhead "
                  f"{result['overhead']['ray']['overhead_per_wave_s']:.2f} s per wave, {args.cores} cores per node")
            print("| nodes | shards | fires | overhead | merge | total | one core |\n|---|---|---|---|---|---|---|")
            for p in result["projection"]:
                print(f"| {p['nodes']} | {p['shards']} | {p['compute_s']:.1f} s | {p['overhead_s']:.1f} s | "
                      f"{p['merge_s']:.1f} s | {p['total_s']:.1f} s | {p['one_core_s']:.0f} s |")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(result, f, indent=2)


if __name__ == "__main__":
    main()
