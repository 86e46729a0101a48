#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The long soak of docs/reliability.md ("Soak"). Builds Release, starts scanprep-server on loopback
# (default flags), measures its capacity with a closed-loop `scanprep load` (4 workers = the
# default max_concurrent_jobs, 60 s), then runs an open loop at 80 % of that rate with fixed
# spacing (a production line's cadence) for DURATION seconds (default 600), sampling the server's
# resident memory every 10 s. Passes when the soak had zero failed calls and memory stayed flat:
# the highest RSS of the last third of the run at most 10 % above the highest RSS of the first
# third, not counting the first minute (which warms pools and heaps up). Peaks over windows of
# minutes, because resident memory cycles by about 25 % over about two minutes as the allocator
# returns freed pages; a leak shows as peaks that keep rising.
# Usage: tools/run-soak.sh [DURATION_SECONDS]
# The job is bun000 + bun045 of ../shared/data registered with bun.conf, else a generated
# 100,000-point scan.
set -euo pipefail
cd "$(dirname "$0")/.."
duration=${1:-600}
bash tools/install-deps.sh
bash tools/build.sh >/dev/null
bin=${BUILD_DIR:-build}
out=$(mktemp -d)
trap 'kill "$server_pid" 2>/dev/null || true; wait 2>/dev/null || true; rm -rf "$out"' EXIT
source tools/lib/local-server.sh
start_local_server "$out/server.log"

data=../shared/data/stanford_bunny_range_scans
if [[ -d "$data" ]]; then
  job=("$data/bun000.ply" "$data/bun045.ply" --conf "$data/bun.conf" --unit m)
else
  job=(--simulate 100000)
fi
load() { "$bin/client/scanprep" load --server "127.0.0.1:$port" "${job[@]}" "$@"; }
field() { python3 -c "import json,sys; print(json.load(open(sys.argv[1]))[sys.argv[2]])" "$@"; }
rss_mib() { awk '/^VmRSS:/ {printf "%.1f", $2 / 1024}' "/proc/$server_pid/status"; }

echo "== capacity: closed loop, 4 workers, 60 s"
load --concurrency 4 --duration 60s --json "$out/capacity.json"
capacity=$(field "$out/capacity.json" jobs_per_s)
rate=$(python3 -c "print(round(0.8 * $capacity, 4))")

echo "== soak: open loop at $rate jobs/s (80 % of $capacity), fixed spacing, ${duration} s"
: >"$out/rss"
(
  start=$SECONDS
  while kill -0 "$server_pid" 2>/dev/null; do
    echo "$((SECONDS - start)) $(rss_mib)" >>"$out/rss"
    sleep 10
  done
) &
sampler=$!
status=0
load --rate "$rate" --arrivals fixed --concurrency 16 --duration "${duration}s" \
  --json "$out/soak.json" || status=$?
kill "$sampler" 2>/dev/null || true

errors=$(field "$out/soak.json" errors)
python3 - "$out/rss" "$duration" "$errors" "$status" <<'PY'
import sys
samples = [tuple(map(float, l.split())) for l in open(sys.argv[1]) if len(l.split()) == 2]
duration, errors, status = float(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
first = max(r for t, r in samples if 60 <= t < max(120, duration / 3))
last = max(r for t, r in samples if t >= duration * 2 / 3)
print("server RSS (MiB) every 10 s:", " ".join(f"{r:.0f}" for _, r in samples))
print(f"highest RSS: first third (after 60 s) {first:.1f} MiB, last third {last:.1f} MiB "
      f"({100 * (last / first - 1):+.1f} %)")
flat = last <= 1.10 * first
print(f"errors: {errors}; memory flat: {'yes' if flat else 'NO'}; load exit status: {status}")
sys.exit(0 if errors == 0 and flat and status == 0 else 1)
PY
