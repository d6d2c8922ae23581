#!/usr/bin/env python3
"""Time the demo's GRIDMET windows stage (`data.windows`) whole and in shards, locally and
on a Ray cluster, check every run wrote the same bytes, and project the CONUS build.

    scripts/bench_windows_shards.py [--shards 3 5 15] [--repeat 2]
        [--ray-address http://127.0.0.1:8265] [--gridmet-bench bench.json] [--json out.json]

Needs the demo's inputs (`build/demo/samples.parquet`, `build/demo/sources/{gridmet,truth}`;
`firecast pipeline run pipelines/demo.yaml --only sources --only ignitions --only samples`
makes them) and a release `firecast` (`$FIRECAST_BIN`, else `$CARGO_TARGET_DIR/release/firecast`,
else `target/release/firecast`). It works in a scratch project (`--work`, default
`.firecast/bench/windows-shards/`) with the inputs hard-linked in, so the repository's
lockfiles and registry are not touched; the artifact store is a folder there (one machine).

With `--ray-address` it also runs on that cluster, e.g. one started with
    .venv/bin/ray start --head --node-ip-address=127.0.0.1 --dashboard-host=127.0.0.1 \\
        --num-cpus=2 --disable-usage-stats
(stop it with `.venv/bin/ray stop`). A first Ray run, not counted, uploads the inputs to the
store (content-addressed: later runs send nothing new).

What it reports per run: the stage's wall time on the driver, each shard's work (its log:
plan = read the samples, list the files, open the grid; read = the shard's files; shard =
everything including writing its part), the merge on the driver, and on Ray each task's time
in the worker (`result.json`: work plus fetching its inputs from the store and uploading its
part). Ray's per-task overhead is the stage's wall time less the merge and the tasks' time in
the workers, per wave of tasks (a wave: as many tasks as the cluster has CPUs); the store's
share of a task is its time in the worker less the shard's work.

With `--gridmet-bench FILE` (the JSON of `firecast --json bench gridmet`) it projects the full
CONUS windows build onto N nodes from the per-file and per-window costs measured there, plus
the hashing, the store's rate, the merge and the Ray overhead measured here (see `project`).
Run it on `bench gridmet`'s CONUS files for store and merge rates at that grid size, e.g.

    firecast --json bench gridmet --dir /tmp/gb/bench --samples 2000 > /tmp/gb/bench.json
    .venv/bin/python scripts/bench_windows_shards.py --gridmet /tmp/gb/bench/gridmet \\
        --random-samples 5547 --variables pr rmin tmmx vs --shards 2 4 \\
        --ray-address http://127.0.0.1:8265 --gridmet-bench /tmp/gb/bench.json

(5,547 windows in one year: the paper's 66,568 over 12 years; `--random-samples` needs
numpy, netCDF4 and pyarrow, which `.venv` has.)
"""

import argparse
import glob
import hashlib
import json
import math
import os
import re
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
INPUTS = ["build/demo/samples.parquet", "build/demo/sources/gridmet", "build/demo/sources/truth"]
OUTPUT = "build/demo/windows"
FILES = ["samples.parquet", "days.parquet", "windows.json"]

STAGE = """stages:
  windows:
    uses: data.windows
{shards}{params}    inputs:
      samples: build/demo/samples.parquet
      gridmet: build/demo/sources/gridmet
{truth}    outputs:
      windows: build/demo/windows
"""
TRUTH = "      truth: build/demo/sources/truth\n"


def firecast_bin():
    if os.environ.get("FIRECAST_BIN"):
        return os.environ["FIRECAST_BIN"]
    target = os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target"))
    return os.path.join(target, "release", "firecast")


def random_samples(nc_path, n, out, seed=1):
    """`n` windows on cells with data, wholly inside the file's year, as `data.negatives`
    writes samples (the columns `data.windows` reads)."""
    import datetime as dt

    import netCDF4
    import numpy as np
    import pyarrow as pa
    import pyarrow.parquet as pq

    ds = netCDF4.Dataset(nc_path)
    var = [v for v in ds.variables if v not in ("lat", "lon", "day", "crs")][0]
    lats, lons = ds["lat"][:], ds["lon"][:]
    mask = ~np.ma.getmaskarray(ds[var][0])
    if mask.shape != (len(lats), len(lons)):
        mask = mask.T
    land = np.argwhere(mask)
    rng = np.random.default_rng(seed)
    cells = land[rng.integers(0, len(land), n)]
    year = int(os.path.basename(nc_path).rsplit("_", 1)[1][:4])
    # Noon MST; the window's 60 days before and 14 after stay in the year.
    start = dt.datetime(year, 1, 1, 19, tzinfo=dt.timezone.utc) + dt.timedelta(days=60)
    span = (dt.datetime(year, 12, 17, tzinfo=dt.timezone.utc) - start).days
    days = rng.integers(0, span + 1, n)
    times = [int((start + dt.timedelta(days=int(d))).timestamp() * 1000) for d in days]
    pq.write_table(pa.table({
        "sample_id": pa.array(np.arange(n, dtype=np.uint32)),
        "latitude": pa.array(lats[cells[:, 0]].astype(float)),
        "longitude": pa.array(lons[cells[:, 1]].astype(float)),
        "event_time": pa.array(times, type=pa.timestamp("ms", tz="UTC")),
        "tier": pa.array(["positive"] * n),
        "source_row": pa.array([None] * n, type=pa.uint64()),
    }), out)


def link_tree(src, dest):
    """Hard-link a file or folder (copy where links are refused)."""
    if os.path.isdir(src):
        os.makedirs(dest, exist_ok=True)
        for name in sorted(os.listdir(src)):
            link_tree(os.path.join(src, name), os.path.join(dest, name))
        return
    os.makedirs(os.path.dirname(dest), exist_ok=True)
    if os.path.exists(dest):
        return
    try:
        os.link(src, dest)
    except OSError:
        shutil.copy2(src, dest)


def digest(folder):
    return {f: hashlib.blake2b(open(os.path.join(folder, f), "rb").read()).hexdigest() for f in FILES}


def run(work, tag, shards, ray_address, variables=None, truth=True):
    """One forced run of the windows stage; returns what was measured."""
    pipeline = f"pipelines/windows-{tag}.yaml"
    with open(os.path.join(work, pipeline), "w") as f:
        f.write(STAGE.format(
            shards=f"    shards: {shards}\n" if shards else "",
            params=f"    params: {{variables: [{', '.join(variables)}]}}\n" if variables else "",
            truth=TRUTH if truth else "",
        ))
    cmd = [firecast_bin(), "--json", "--no-progress", "--store", os.path.join(work, "store"),
           "pipeline", "run", pipeline, "--force"]
    if ray_address:
        cmd += ["--executor", "ray", "--ray-address", ray_address]
    else:
        cmd += ["--executor", "local"]
    t0 = time.monotonic()
    out = subprocess.run(cmd, cwd=work, capture_output=True, text=True)
    wall = time.monotonic() - t0
    if out.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed:\n{out.stdout}\n{out.stderr}")
    stage = json.loads(out.stdout)["stages"][0]
    log = open(os.path.join(work, ".firecast/logs", stage["run_id"] + ".log")).read()
    work_s = [float(m) for m in re.findall(r"shard \d+/\d+: variables .* shard ([0-9.]+) s", log)]
    plan_s = [float(m) for m in re.findall(r"; plan ([0-9.]+) s", log)]
    merge = re.search(r"merged \d+ shards in ([0-9.]+) s", log)
    fetched = {}
    for shard, mb in re.findall(r"shard (\d+)/\d+: fetched \d+ of \d+ files of input `[^`]+` \([^,]+, ([0-9.]+) of", log):
        fetched[shard] = fetched.get(shard, 0.0) + float(mb) / 1000
    worker_s = []
    for path in sorted(glob.glob(os.path.join(work, "store/remote", stage["run_id"], "**/result.json"),
                                 recursive=True)):
        worker_s.append(json.load(open(path))["seconds"])
    return {
        "executor": "ray" if ray_address else "local",
        "shards": shards or 1,
        "stage_s": stage["duration_secs"],
        "command_s": wall,
        "shard_work_s": work_s,
        "shard_plan_s": plan_s,
        "merge_s": float(merge.group(1)) if merge else 0.0,
        "worker_s": worker_s,
        "fetched_gb": [fetched[k] for k in sorted(fetched, key=int)],
        "digest": digest(os.path.join(work, OUTPUT)),
    }


def summarise(runs, cpus):
    """Median over repeats, with the per-task overhead on Ray."""
    r0 = runs[0]
    med = lambda key: statistics.median(r[key] for r in runs)
    row = {
        "executor": r0["executor"],
        "shards": r0["shards"],
        "stage_s": med("stage_s"),
        "merge_s": med("merge_s"),
        "shard_work_s": [statistics.median(v) for v in zip(*[r["shard_work_s"] for r in runs])],
        "shard_plan_s": [statistics.median(v) for v in zip(*[r["shard_plan_s"] for r in runs])],
        "worker_s": [statistics.median(v) for v in zip(*[r["worker_s"] for r in runs])],
        "fetched_gb": [statistics.median(v) for v in zip(*[r["fetched_gb"] for r in runs])],
    }
    if r0["executor"] == "ray":
        worker = row["worker_s"]
        waves = math.ceil(row["shards"] / cpus)
        # The tasks' time in their workers packed onto the CPUs, as well as it can be: the
        # rest is Ray's (submitting, scheduling, starting `firecast`, polling).
        busy = max(max(worker), sum(worker) / cpus)
        row["waves"] = waves
        row["overhead_per_wave_s"] = (row["stage_s"] - row["merge_s"] - busy) / waves
        if row["shard_work_s"]:
            row["store_per_task_s"] = statistics.median(
                w - s for w, s in zip(row["worker_s"], row["shard_work_s"]))
            if row["fetched_gb"]:
                row["fetched_gb"] = statistics.median(row["fetched_gb"])
    return row


def project(costs, nodes, cores=16, windows=66_568, variables=15, years=12, gb_per_file=1.4,
            days=75, disk_gb_s=1.0):
    """The CONUS windows build (`windows` windows, `variables` x `years` files of
    `gb_per_file` GB) in one shard per variable on `nodes` nodes of `cores` cores.

    A shard reads its variable's `years` files plus the grid's file (the first variable's
    first year); every file costs `file_core_s` plus `window_var_core_s` per window it serves
    (from `firecast bench gridmet`) plus hashing it (`source_hashes`), all on one core; a node
    runs its shards' files in parallel on its cores. On Ray a task first fetches its files
    through the store (which leaves them in the page cache), tasks start with Ray's overhead,
    and the driver fetches the parts and merges (Parquet). For comparison: the whole stage on
    one node whose disk reads the files cold at `disk_gb_s`.
    """
    c = costs
    per_file = (c["file_core_s"] + windows / years * c["window_var_core_s"]
                + gb_per_file * c["hash_core_s_per_gb"])
    shards_per_node = math.ceil(variables / nodes)
    compute = shards_per_node * years * per_file / cores
    fetch = shards_per_node * (years + 1) * gb_per_file / c["store_gb_s"]
    merge = windows * variables * (c["merge_s_per_window_var"] + days * 4 / 1e9 / c["store_gb_s"])
    return {
        "nodes": nodes,
        "cores": cores,
        "compute_s": compute,
        "fetch_s": fetch,
        "overhead_s": c["overhead_per_wave_s"],
        "merge_s": merge,
        "total_s": compute + fetch + c["overhead_per_wave_s"] + merge,
        "one_node_unsharded_s": (variables * years * (per_file / cores + gb_per_file / disk_gb_s)
                                 + windows * variables * c["merge_s_per_window_var"]),
    }


def hash_core_s_per_gb(folder):
    """CPU seconds per GB of firecast's BLAKE3: a `cmd` stage over `folder`, cold hash cache."""
    with tempfile.TemporaryDirectory() as tmp:
        os.makedirs(os.path.join(tmp, "pipelines"))
        os.symlink(folder, os.path.join(tmp, "g"))
        with open(os.path.join(tmp, "pipelines/h.yaml"), "w") as f:
            f.write("stages:\n  h:\n    uses: cmd\n    params: {command: \"echo > ${outputs.o}\"}\n"
                    "    inputs: {g: g}\n    outputs: {o: o.txt}\n")
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        subprocess.run([firecast_bin(), "--no-progress", "pipeline", "run", "pipelines/h.yaml", "-j", "1"],
                       cwd=tmp, check=True, capture_output=True)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
    size = sum(os.path.getsize(p) for p in glob.glob(os.path.join(folder, "*")))
    return (after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime) / (size / 1e9)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--shards", type=int, nargs="+", default=[3, 5, 15])
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--ray-address")
    ap.add_argument("--ray-cpus", type=int, default=2, help="CPUs of the Ray cluster (for waves)")
    ap.add_argument("--work", help="scratch project [default: .firecast/bench/windows-shards/{demo,gridmet}]")
    ap.add_argument("--gridmet", help="another GRIDMET folder (e.g. `bench gridmet`'s CONUS files)")
    ap.add_argument("--samples", help="the samples for --gridmet (Parquet, as `data.negatives` writes)")
    ap.add_argument("--variables", nargs="+", help="the variables to extract from --gridmet")
    ap.add_argument("--random-samples", type=int, metavar="N",
                    help="instead of --samples: N random windows in the first variable's first file")
    ap.add_argument("--gridmet-bench", help="JSON of `firecast --json bench gridmet`")
    ap.add_argument("--windows", type=int, default=66_568, help="CONUS windows to project")
    ap.add_argument("--json", help="write every number here")
    a = ap.parse_args()

    demo = a.gridmet is None
    work = os.path.abspath(a.work or os.path.join(ROOT, ".firecast/bench/windows-shards",
                                                  "demo" if demo else "gridmet"))
    os.makedirs(os.path.join(work, "pipelines"), exist_ok=True)
    sources = dict(zip(INPUTS, [os.path.join(ROOT, rel) for rel in INPUTS]))
    if not demo:
        if not (a.variables and (a.samples or a.random_samples)):
            sys.exit("--gridmet needs --variables and --samples or --random-samples")
        if a.random_samples:
            a.samples = os.path.join(work, "random-samples.parquet")
            first = sorted(glob.glob(os.path.join(a.gridmet, f"{a.variables[0]}_*.nc")))[0]
            random_samples(first, a.random_samples, a.samples)
        sources = {INPUTS[0]: os.path.abspath(a.samples), INPUTS[1]: os.path.abspath(a.gridmet)}
    for rel, src in sources.items():
        if not os.path.exists(src):
            sys.exit(f"{src} is missing: run the demo's sources, ignitions and samples stages first")
        dest = os.path.join(work, rel)
        if os.path.isdir(dest) and not os.path.islink(dest):
            shutil.rmtree(dest)
        elif os.path.lexists(dest):
            os.remove(dest)
        link_tree(src, dest)

    configs = [("local", None)] + [("local", n) for n in a.shards]
    options = {"variables": a.variables, "truth": demo}
    if a.ray_address:
        run(work, "ray-warmup", None, a.ray_address, **options)
        configs += [("ray", None)] + [("ray", n) for n in a.shards]
    rows, reference = [], None
    for executor, shards in configs:
        address = a.ray_address if executor == "ray" else None
        runs = [run(work, f"{executor}-{shards or 1}", shards, address, **options) for _ in range(a.repeat)]
        for r in runs:
            if reference is None:
                reference = r["digest"]
            if r["digest"] != reference:
                sys.exit(f"{executor} with {shards} shards wrote other bytes: {r['digest']} vs {reference}")
        row = summarise(runs, a.ray_cpus)
        rows.append(row)
        extra = ""
        if "overhead_per_wave_s" in row:
            extra = f", Ray overhead {row['overhead_per_wave_s']:.2f} s per wave of {a.ray_cpus}"
            if "store_per_task_s" in row:
                extra += f", store traffic {row['store_per_task_s']:.2f} s per task"
        work_s = row["shard_work_s"]
        shard_text = f", shards' work {min(work_s):.2f}-{max(work_s):.2f} s" if work_s else ""
        worker_text = (f", in the worker {min(row['worker_s']):.2f}-{max(row['worker_s']):.2f} s"
                       if row["worker_s"] else "")
        print(f"{executor:5} shards {row['shards']:2}: stage {row['stage_s']:.2f} s{shard_text}"
              f"{worker_text}, merge {row['merge_s']:.2f} s{extra}", flush=True)
    same = os.path.join(ROOT, OUTPUT)
    if demo and os.path.isdir(same):
        print("same bytes as the demo's own build/demo/windows:", digest(same) == reference)
    result = {"runs": rows}

    if a.gridmet_bench:
        bench = json.load(open(a.gridmet_bench))
        threads = bench.get("threads", 1)
        per_window = max((bench["firecast_seconds"] - bench["firecast_quarter_seconds"])
                         / (0.75 * bench["windows"]), 0.0)
        per_file = max((bench["firecast_seconds"] - per_window * bench["windows"]) / bench["files"], 0.0)
        gridmet = os.path.join(work, INPUTS[1])
        manifest = json.load(open(os.path.join(work, OUTPUT, "windows.json")))
        window_vars = manifest["report"]["samples_out"] * len(manifest["config"]["variables"])
        ray_rows = [r for r in rows if r["executor"] == "ray" and r["shards"] > 1]
        local_rows = [r for r in rows if r["executor"] == "local" and r["shards"] > 1]
        costs = {
            # bench gridmet's wall times on `threads` threads, as core-seconds.
            "file_core_s": per_file * threads,
            "window_var_core_s": per_window * threads / bench["variables"],
            "hash_core_s_per_gb": hash_core_s_per_gb(gridmet),
            "merge_s_per_window_var": statistics.median(r["merge_s"] for r in local_rows) / window_vars,
            "overhead_per_wave_s": (statistics.median(r["overhead_per_wave_s"] for r in ray_rows)
                                    if ray_rows else float("nan")),
            "store_gb_s": (statistics.median(r["fetched_gb"] / r["store_per_task_s"]
                                             for r in ray_rows if "store_per_task_s" in r)
                           if ray_rows else float("nan")),
        }
        result["costs"] = costs
        print("costs:", json.dumps(costs))
        result["projection"] = []
        for store_gb_s in [costs["store_gb_s"], 1.0]:
            for nodes in [1, 2, 4, 8, 15]:
                p = project(dict(costs, store_gb_s=store_gb_s), nodes, windows=a.windows)
                result["projection"].append(p)
                print(f"store {store_gb_s:.2f} GB/s, {nodes:2} node(s) x {p['cores']} cores: "
                      f"{p['total_s']:.0f} s (compute {p['compute_s']:.1f}, fetch {p['fetch_s']:.1f}, "
                      f"Ray {p['overhead_s']:.1f}, merge {p['merge_s']:.1f}); unsharded on one node "
                      f"reading its disk at 1 GB/s: {p['one_node_unsharded_s']:.0f} s")
    if a.json:
        json.dump(result, open(a.json, "w"), indent=2)


if __name__ == "__main__":
    main()
