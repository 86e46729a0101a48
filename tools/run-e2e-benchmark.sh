#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The end-to-end service benchmark: for each point count, a generated two-scan cloud
# (`scanprep simulate --scans 2`) goes through scanprep-server on loopback with 1 and 2 worker
# threads, the whole default pipeline. `scanprep process` reads the files, uploads, the server
# processes, the client downloads and writes the result; its --report_json gives each phase.
# Prints docs/benchmarks.md table rows (points, threads, case, seconds, points/s, peak resident memory of the
# server) for "service: upload / processing / download / end to end", then per run the server's
# peak resident memory above its idle baseline (/proc VmHWM after the job minus VmRSS after
# startup) per point, the transport's share of the processing time, and the 2-thread speed-up.
# Usage: tools/run-e2e-benchmark.sh [--no-header] [POINTS...]   (default 1000000 4000000)
# Environment: BUILD_DIR (default build), THREADS (default "1 2"), SKIP_BUILD=1 when the caller
# has just built, PARAMS (space-separated name=value overrides for every job, e.g.
# "correction.radius_scale=100", the worst case of server/admission/memory_reservation.h), PRESET (a
# preset for every job, e.g. "paper").
set -euo pipefail
cd "$(dirname "$0")/.."
header=1
if [[ ${1:-} == --no-header ]]; then header=0; shift; fi
sizes=("$@")
((${#sizes[@]})) || sizes=(1000000 4000000)
read -ra threads <<<"${THREADS:-1 2}"
params=()
for p in ${PARAMS:-}; do params+=(--param "$p"); done
[[ -n ${PRESET:-} ]] && params+=(--preset "$PRESET")
source tools/lib/bench-setup.sh  # cli, bin, work, server_pid, cleanup on exit

# kB value of a /proc/PID/status field.
status_kb() { awk -v f="$2:" '$1 == f {print $2}' "/proc/$1/status"; }

if ((header)); then
  echo "| points | threads | case | seconds | points/s | peak RSS (MiB) |"
  echo "|---:|---:|---|---:|---:|---:|"
fi
notes=()
for n in "${sizes[@]}"; do
  "$cli" simulate --points "$n" --scans 2 -o "$work/sim.ply" >/dev/null
  declare -A seconds=()  # threads → "processing end-to-end"
  for t in "${threads[@]}"; do
    start_local_server "$work/server.log" --metrics_listen= --threads "$t"
    sleep 1  # let startup settle before taking the idle baseline
    idle_kb=$(status_kb "$server_pid" VmRSS)
    "$cli" process "$work"/sim_*.ply --job "$work/sim.job.json" -o "$work/out.ply" \
      --server "127.0.0.1:$port" --report_json "$work/report.json" "${params[@]}" >/dev/null
    peak_kb=$(status_kb "$server_pid" VmHWM)
    stop_local_server || true
    server_pid=
    summary=$(python3 - "$work/report.json" "$t" "$idle_kb" "$peak_kb" <<'PY'
import json, sys
report = json.load(open(sys.argv[1]))
threads, idle_kb, peak_kb = int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
points = int(report["points_received"])
p = report["phases"]
for case, key in [("upload", "upload_seconds"), ("processing", "processing_seconds"),
                  ("download", "download_seconds"), ("end to end", "total_seconds")]:
    s = p[key]
    print(f"| {points:,} | {threads} | service: {case} | {s:.3f} | {points / s:,.0f} | "
          f"{peak_kb / 1024:,.0f} |")
transport = (p["upload_seconds"] + p["download_seconds"]) / p["processing_seconds"]
print(f"note {points:,} points, {threads} threads: server peak RSS above idle: "
      f"{(peak_kb - idle_kb) * 1024 / points:.0f} bytes/point (idle {idle_kb / 1024:.0f} MiB); "
      f"upload + download = {100 * transport:.1f} % of processing; "
      f"{report['points_returned']} points returned")
print(f"seconds {p['processing_seconds']} {p['total_seconds']}")
PY
    )
    grep '^|' <<<"$summary"
    notes+=("$(sed -n 's/^note //p' <<<"$summary")")
    seconds[$t]=$(sed -n 's/^seconds //p' <<<"$summary")
  done
  if [[ -n ${seconds[1]:-} && -n ${seconds[2]:-} ]]; then
    notes+=("$(python3 - ${seconds[1]} ${seconds[2]} "$n" <<'PY'
import sys
p1, e1, p2, e2 = map(float, sys.argv[1:5])
print(f"about {int(sys.argv[5]):,} points: 2 threads give {p1 / p2:.2f}x the 1-thread speed in "
      f"processing, {e1 / e2:.2f}x end to end")
PY
    )")
  fi
  unset seconds
done
echo
printf '%s\n' "${notes[@]}"
