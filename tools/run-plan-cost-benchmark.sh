#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The plan-cost model against measured runs (docs/plan-cost.md): the ordinary two-scan simulated
# cloud (`scanprep simulate --scans 2`) through one local server with no plan-cost limit, the
# default job three times, then each costly parameter alone and in pairs. For each case: the
# model's estimate (the report's estimated_plan_cost), the sum of the stages' seconds over the
# default job's (what the model estimates), the end-to-end seconds over the default's (upload,
# duplicates and result included) and what the server's default limit of 3x does with it.
# Prints a markdown table; exits 1 when the model admits a case measured over 3.5x, or refuses
# one measured under 2.5x, or estimates any case below 0.8x its measured ratio.
# Usage: tools/run-plan-cost-benchmark.sh [POINTS]   (default 100000)
# Environment: BUILD_DIR (default build), SKIP_BUILD=1 when the caller has just built, THREADS
# (server worker threads, default 2).
set -euo pipefail
cd "$(dirname "$0")/.."
points=${1:-100000}
source tools/lib/bench-setup.sh  # cli, bin, work, server_pid, cleanup on exit

"$cli" simulate --points "$points" --scans 2 -o "$work/sim.ply" >/dev/null
start_local_server "$work/server.log" --threads "${THREADS:-2}" --max_plan_cost=0
k64="neighbourhoods.k=64"
minr="neighbourhoods.min_radius_mm=10000"
mitra="normals.radius_mode=mitra"
mitra_c="$mitra normals.mitra_c1=1000 normals.mitra_c2=1000"
cases=(
  "default|" "default|" "default|"
  "k 40|neighbourhoods.k=40" "k 64|$k64"
  "every k 64|$k64 outliers.k=64 outliers.loop_k=64 normals.orientation_k=64"
  "LoOP|outliers.method=loop" "Mitra|$mitra" "Mitra c1 1000|$mitra normals.mitra_c1=1000"
  "Mitra c2 1000|$mitra normals.mitra_c2=1000" "Mitra c1, c2 1000|$mitra_c"
  "min radius 1 mm|neighbourhoods.min_radius_mm=1" "min radius 10 m|$minr"
  "correction radius ×10|correction.radius_scale=10"
  "correction radius ×100|correction.radius_scale=100" "correction 1000 rounds|correction.rounds=1000"
  "correction both|correction.radius_scale=100 correction.rounds=1000"
  "smoothing 3 passes|smoothing.iterations=3" "smoothing 7 passes|smoothing.iterations=7"
  "registration 100 steps|registration.max_iterations=100"
  "correction ×100 + min radius|correction.radius_scale=100 $minr"
  "correction ×100 + k 64|correction.radius_scale=100 $k64"
  "k 64 + min radius|$k64 $minr" "k 64 + 7 passes|$k64 smoothing.iterations=7"
  "min radius + 7 passes|$minr smoothing.iterations=7"
  "Mitra c 1000 + k 64|$mitra_c $k64" "Mitra c 1000 + min radius|$mitra_c $minr"
  "every edge (issue 38)|$k64 outliers.k=64 outliers.method=loop outliers.loop_k=64 normals.orientation_k=64 $mitra_c $minr correction.radius_scale=100 correction.rounds=1000 smoothing.iterations=7"
)
: >"$work/results"
for entry in "${cases[@]}"; do
  name=${entry%%|*}
  params=()
  for p in ${entry#*|}; do params+=(--param "$p"); done
  start=$(date +%s.%N)
  "$cli" process --server "127.0.0.1:$port" "$work"/sim_*.ply --job "$work/sim.job.json" \
    -o "$work/out.ply" --report_json "$work/report.json" "${params[@]}" >/dev/null \
    2>"$work/cli.log" || { cat "$work/cli.log" >&2; exit 1; }
  end=$(date +%s.%N)
  python3 - "$work/report.json" "$name" "$start" "$end" >>"$work/results" <<'PY'
import json, sys
report = json.load(open(sys.argv[1]))
stages = sum(float(s.get("seconds", 0)) for s in report["stages"])
print("\t".join([sys.argv[2], str(report.get("estimated_plan_cost", 1)), str(stages),
                 str(float(sys.argv[4]) - float(sys.argv[3]))]))
PY
done
stop_local_server || true
server_pid=

python3 - "$work/results" <<'PY'
import statistics, sys
rows = [line.rstrip("\n").split("\t") for line in open(sys.argv[1])]
default = [r for r in rows if r[0] == "default"]
stages0 = statistics.median(float(r[2]) for r in default)
wall0 = statistics.median(float(r[3]) for r in default)
print(f"default job: stages {stages0:.3f} s, end to end {wall0:.3f} s (median of {len(default)})\n")
print("| case | estimate | stages measured | end to end | at the default limit (3×) |")
print("|---|---:|---:|---:|---|")
bad = []
for name, estimate, stages, wall in rows:
    if name == "default":
        continue
    estimate, measured = float(estimate), float(stages) / stages0
    verdict = "admitted" if estimate <= 3 else "refused (JOB_TOO_COSTLY)"
    if (estimate <= 3 and measured > 3.5) or (estimate > 3 and measured < 2.5) or \
            estimate < 0.8 * measured:
        bad.append(name)
        verdict += " — WRONG"
    print(f"| {name} | {estimate:.2f} | {measured:.2f} | {float(wall) / wall0:.2f} | {verdict} |")
print(f"\n{len(bad)} cases the model judges wrongly" + (": " + ", ".join(bad) if bad else ""))
sys.exit(1 if bad else 0)
PY
