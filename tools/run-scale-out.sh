#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Scale-out as the MES sees it: `scanprep load` against one scanprep-server pinned to one core,
# then against two, each pinned to its own core, behind one address list (round-robin); then the
# two again with one of them killed (SIGKILL) halfway through the run. Prints jobs/s, the
# speed-up, and the errors and retries of the run with the kill (a call that ends UNAVAILABLE is
# sent again: no job should be lost).
# Usage: tools/run-scale-out.sh [POINTS_PER_JOB] [SECONDS]   (default 200000 20)
set -euo pipefail
cd "$(dirname "$0")/.."
points=${1:-200000}
seconds=${2:-20}
source tools/lib/bench-setup.sh  # cli, bin, work, server_pid, cleanup on exit
(($(nproc) >= 2)) || { echo "needs 2 cores" >&2; exit 1; }
pids=()
trap 'kill -KILL "${pids[@]}" 2>/dev/null || true; cleanup' EXIT

start_replica() {  # CPU; appends to pids and targets
  PIN=$1 start_local_server "$work/server$1.log" --threads=1 --metrics_listen=
  pids+=("$server_pid")
  targets+=("127.0.0.1:$port")
}
load() {  # TARGET NAME: runs the load, prints jobs/s
  "$cli" load --server "$1" --concurrency 4 --duration "${seconds}s" --timeout 120s \
    --simulate "$points" --json "$work/$2.json" >"$work/$2.txt"
  python3 -c 'import json, sys; print(json.load(open(sys.argv[1]))["jobs_per_s"])' "$work/$2.json"
}
stop_all() { kill -TERM "${pids[@]}" 2>/dev/null || true; wait "${pids[@]}" 2>/dev/null || true; pids=(); }

targets=()
start_replica 0
one=$(load "${targets[0]}" one)
stop_all

targets=()
start_replica 0
start_replica 1
two=$(load "$(IFS=,; echo "${targets[*]}")" two)
stop_all

targets=()
start_replica 0
start_replica 1
( sleep "$((seconds / 2))"; kill -KILL "${pids[0]}" ) &
load "$(IFS=,; echo "${targets[*]}")" killed >/dev/null
stop_all

python3 - "$work" "$one" "$two" "$points" "$seconds" <<'PY'
import json, sys
work, one, two, points, seconds = sys.argv[1], float(sys.argv[2]), float(sys.argv[3]), *sys.argv[4:]
killed = json.load(open(f"{work}/killed.json"))
print(f"scale-out: {int(points):,} points per job, 4 calls in flight, {seconds} s per run, "
      "each replica --threads=1 pinned to its own core")
print("| replicas | jobs/s | speed-up |")
print("|---:|---:|---:|")
print(f"| 1 | {one:.3f} | 1.00× |")
print(f"| 2 | {two:.3f} | {two / one:.2f}× |")
print(f"one of 2 replicas killed (SIGKILL) after {int(seconds) // 2} s: {killed['jobs']} jobs ok, "
      f"{killed['errors']} errors, {killed['retries']} retries")
PY
