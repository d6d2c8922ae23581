#!/bin/bash
# The whole demo locally and on a two-node loopback Ray cluster with an s3:// store (moto),
# each in a fresh clone of this repository, then the two lockfiles compared (run ids aside).
#
#   scripts/demo_on_ray.sh [WORK_DIR]      (default /tmp/firecast-demo-on-ray)
#
# Needs `cargo xtask setup` (.venv with ray and moto) and a release build
# ($FIRECAST_BIN, else $CARGO_TARGET_DIR/release/firecast, else ~/.cache/firecast/target/...).
# Uses ports 5077 (moto), 6379 and 8265 (Ray); stops the cluster it started.
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
WORK=${1:-/tmp/firecast-demo-on-ray}
BIN=${FIRECAST_BIN:-${CARGO_TARGET_DIR:-$HOME/.cache/firecast/target}/release/firecast}
V=$ROOT/.venv
export FIRECAST_VENV=$V
rm -rf "$WORK" && mkdir -p "$WORK"
git clone -q "$ROOT" "$WORK/local"
git clone -q "$ROOT" "$WORK/ray"

(cd "$WORK/local" && /usr/bin/time -f "local: %e s" "$BIN" --no-progress pipeline run pipelines/demo.yaml \
    > "$WORK/local.out" 2>&1) || { tail "$WORK/local.out"; exit 1; }
tail -2 "$WORK/local.out"

"$V/bin/moto_server" -H 127.0.0.1 -p 5077 > "$WORK/moto.log" 2>&1 &
MOTO=$!
cleanup() { "$V/bin/ray" stop > /dev/null 2>&1 || true; kill "$MOTO" 2> /dev/null || true; }
trap cleanup EXIT
sleep 3
export AWS_ENDPOINT_URL=http://127.0.0.1:5077 AWS_ALLOW_HTTP=true AWS_REGION=us-east-1 \
    AWS_ACCESS_KEY_ID=test AWS_SECRET_ACCESS_KEY=test
"$V/bin/python" -c "import boto3; boto3.client('s3').create_bucket(Bucket='fc-demo')"
"$V/bin/ray" start --head --node-ip-address=127.0.0.1 --dashboard-host=127.0.0.1 --num-cpus=1 \
    --disable-usage-stats > "$WORK/ray-head.log" 2>&1
"$V/bin/ray" start --address=127.0.0.1:6379 --node-ip-address=127.0.0.1 --num-cpus=1 \
    --disable-usage-stats > "$WORK/ray-worker.log" 2>&1
(cd "$WORK/ray" && /usr/bin/time -f "ray: %e s" "$BIN" --no-progress --store s3://fc-demo/store \
    pipeline run pipelines/demo.yaml --executor ray --ray-address http://127.0.0.1:8265 \
    > "$WORK/ray.out" 2>&1) || { tail "$WORK/ray.out"; exit 1; }
tail -2 "$WORK/ray.out"

"$V/bin/python" - "$WORK/local/pipelines/demo.lock" "$WORK/ray/pipelines/demo.lock" <<'PY'
import sys, yaml
a, b = (yaml.safe_load(open(p)) for p in sys.argv[1:])
strip = lambda d: {k: {f: v for f, v in s.items() if f != "run_id"} for k, s in d["stages"].items()}
sa, sb = strip(a), strip(b)
diff = sorted(k for k in sa.keys() | sb.keys() if sa.get(k) != sb.get(k))
print(f"{len(sa)} stages locally, {len(sb)} on Ray; differing: {diff or 'none'}")
sys.exit(1 if diff else 0)
PY
