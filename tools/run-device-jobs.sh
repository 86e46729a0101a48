#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The large-job figures of issue 38 on a many-core machine that has none of the project's
# packages: jobs of the same part at growing density (`scanprep simulate --points N --scans 2
# --seed 7`) through scanprep-server and the CLI from a bundle, then the scaling benchmark
# (tools/run-scaling-benchmark.sh) from the same bundle. Bash and coreutils only.
# Per job it keeps the CLI's --report_json and a line "points threads seconds peak_kb idle_kb" in
# OUT_DIR/jobs.txt; the tables are made here with tools/run-device-jobs.sh --table OUT_DIR.
# Usage: tools/run-device-jobs.sh OUT_DIR [POINTS...]   (default 1000000 4000000 16000000)
# Environment: BUNDLE (default .bundle, made by ../shared/tools/portable-bundle.sh with
# scanprep-server, scanprep and pipeline_bench), THREADS (server threads, default all cores),
# SCALING_THREADS (default "1 2 8 16"; empty skips the scaling benchmark).
set -euo pipefail
cd "$(dirname "$0")/.."

if [[ ${1:-} == --table ]]; then
  python3 - "$2" <<'PY'
import json, os, sys
out = sys.argv[1]
print("| points | threads | density /mm² | processing s | end to end s | peak RSS above idle, B/point | points returned |")
print("|---:|---:|---:|---:|---:|---:|---:|")
for line in open(os.path.join(out, "jobs.txt")):
    n, threads, seconds, peak_kb, idle_kb = line.split()
    report = json.load(open(os.path.join(out, f"report_{n}.json")))
    phases = report["phases"]
    points = int(report["points_received"])
    density = next((v for s in report.get("stages", []) for k, v in s.get("parameters", {}).items()
                    if k.endswith(".density_per_mm2")), float("nan"))
    print(f"| {points:,} | {threads} | {density:,.0f} | {phases['processing_seconds']:.1f} | "
          f"{phases['total_seconds']:.1f} | {(int(peak_kb) - int(idle_kb)) * 1024 / points:.0f} | "
          f"{int(report['points_returned']):,} |")
    for s in report.get("stages", []):
        print(f"  - {s['name']}: {s.get('seconds', float('nan')):.2f} s")
PY
  exit 0
fi

out=$1
shift
sizes=("$@")
((${#sizes[@]})) || sizes=(1000000 4000000 16000000)
bundle=${BUNDLE:-.bundle}
threads=${THREADS:-$(nproc)}
run() { bash "$bundle/run" "$@"; }
# The bundle's launcher execs the server, so $! is the server's pid.
server_cmd=(bash "$bundle/run" scanprep-server)
source tools/lib/local-server.sh
status_kb() {
  local key value _
  while read -r key value _; do
    [[ $key == "$2:" ]] && { echo "$value"; return; }
  done <"/proc/$1/status"
}
work=$(mktemp -d)
server_pid=
trap '[[ -n $server_pid ]] && kill -KILL "$server_pid" 2>/dev/null; rm -rf "$work"' EXIT
mkdir -p "$out"
: >"$out/jobs.txt"
for n in "${sizes[@]}"; do
  echo "simulating $n points" >&2
  run scanprep simulate --points "$n" --scans 2 --seed 7 -o "$work/sim.ply" >/dev/null
  start_local_server "$work/server.log" --metrics_listen= --threads "$threads" \
    --max_points_per_job=$((n + n / 10))
  sleep 1
  idle_kb=$(status_kb "$server_pid" VmRSS)
  start_ms=$(($(date +%s%N) / 1000000))
  run scanprep process "$work"/sim_*.ply --job "$work/sim.job.json" -o "$work/out.ply" \
    --server "127.0.0.1:$port" --report_json "$out/report_$n.json" --progress plain \
    2>"$out/progress_$n.txt" >/dev/null || { tail -5 "$out/progress_$n.txt" >&2; }
  ms=$(($(date +%s%N) / 1000000 - start_ms))
  seconds=$((ms / 1000)).$(printf '%03d' $((ms % 1000)))
  peak_kb=$(status_kb "$server_pid" VmHWM)
  stop_local_server || true
  server_pid=
  echo "$n $threads $seconds $peak_kb $idle_kb" | tee -a "$out/jobs.txt" >&2
  rm -f "$work"/sim* "$work/out.ply"
done
if [[ -n ${SCALING_THREADS-1 2 8 16} ]]; then
  read -ra scaling <<<"${SCALING_THREADS-1 2 8 16}"
  BENCH="bash $bundle/run pipeline_bench" RESULTS="$out/scaling.jsonl" \
    bash tools/run-scaling-benchmark.sh "${scaling[@]}" 2>&1 | tail -3 >&2
fi
