#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Runs every benchmark case (tests/bench/pipeline_bench: stages, neighbour graph, whole pipeline,
# bare nanoflann baseline at 100k/1M/4M points, 1 and 2 threads; the pipeline on 4M points at the
# 1M density), then, when it was built (only where libpcl-dev is installed), the PCL baseline
# tests/bench/pcl_chain_bench (PCL's chain and each of its steps, rows pcl_*), and prints the docs/benchmarks.md
# table (points, threads, case, seconds, points/s, peak resident memory). Then the end-to-end service
# benchmark (tools/run-e2e-benchmark.sh) adds its rows to the same table: at the point counts the
# filter names (numbers of 1000 or more; all of 1 M and 4 M when it names none), with the thread
# count the filter ends with (/N/T), else with 1 and 2 threads. The hostile-input family
# (BM_Hostile/*, docs/hostile-inputs.md) runs only when the filter names it ('Hostile'), without
# these service rows: its service side is tools/run-hostile-benchmark.sh.
# A case that fails (a refused parameter) shows its message instead of its numbers.
# Usage: tools/run-benchmarks.sh [BENCHMARK_FILTER]   e.g. '/1000000/2' for 1 M points, 2 threads
# Environment: CASE_TIMEOUT (seconds; a case still running then is stopped and shown as
# FAIL-timeout; default none).
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/install-deps.sh
command -v python3 >/dev/null || { apt-get update -qq && apt-get install -y -qq python3-minimal; }
bash tools/build.sh >/dev/null
out=$(mktemp)
# Each case in its own process, so peak resident memory belongs to that case alone.
run_cases() {  # BENCHMARK_BINARY; appends one JSON line per case matching the filter to $out
  local cases c
  # The hostile-input family only when asked for by name: on unbounded code its cases may not end.
  mapfile -t cases < <("$1" --benchmark_list_tests --benchmark_filter="${filter}" 2>/dev/null |
    if [[ $filter == *Hostile* ]]; then cat; else grep -v '^BM_Hostile/'; fi)
  for c in "${cases[@]}"; do
    if json=$(timeout "${CASE_TIMEOUT:-0}" "$1" --benchmark_filter="^${c}\$" \
      --benchmark_format=json 2>/dev/null); then
      python3 -c '
import json, sys
for b in json.load(sys.stdin)["benchmarks"]:
    print(json.dumps(b))' <<<"$json" >>"$out"
    else
      local rc=$?
      python3 -c '
import json, sys
rc = int(sys.argv[2])
reason = (f"FAIL-timeout after {sys.argv[3]} s" if rc == 124 else
          f"FAIL: exit {rc}" + (f" (signal {rc - 128})" if rc > 128 else ""))
print(json.dumps({"name": sys.argv[1], "error_occurred": True, "error_message": reason}))' \
        "$c" "$rc" "${CASE_TIMEOUT:-0}" >>"$out"
    fi
  done
}
filter=${1:-.}
run_cases build/tests/bench/pipeline_bench
if [[ -x build/tests/bench/pcl_chain_bench ]]; then
  run_cases build/tests/bench/pcl_chain_bench
else
  echo "PCL baseline (pcl_chain_bench) not built: libpcl-dev is not installed" >&2
fi
echo "machine: $(nproc) cores, $(free -g | awk "/Mem:/ {print \$2}") GiB, $(. /etc/os-release; echo "$PRETTY_NAME")"
python3 - "$out" <<'PY'
import json, sys
rows = [json.loads(l) for l in open(sys.argv[1])]
pcl = {"BM_PclChain": "pcl_chain", "BM_PclStatisticalOutlierRemoval": "pcl_sor",
       "BM_PclNormalEstimationOMP": "pcl_normals", "BM_PclMovingLeastSquares": "pcl_mls",
       "BM_PclVoxelGrid": "pcl_voxel"}
print("| points | threads | case | seconds | points/s | peak RSS (MiB) |")
print("|---:|---:|---|---:|---:|---:|")
for b in rows:
    name = b["name"].split("/")
    case = {"RunPipelineCase": name[1], "BM_Hostile": f"hostile: {name[1]}"}.get(
        name[0], pcl.get(name[0], name[0].removeprefix("BM_")))
    if b.get("error_occurred"):  # no counters: points and threads are the name's arguments
        points, threads = [int(part) for part in name if part.isdigit()][:2]
        print(f"| {points:,} | {threads} | {case} | {b['error_message']} | | |")
        continue
    seconds = b["real_time"] / 1e3  # ms
    print(f"| {int(b['points']):,} | {int(b['threads'])} | {case} | {seconds:.3f} | "
          f"{b['points_per_second']:,.0f} | {b['peak_rss_bytes'] / 2**20:,.0f} |")
PY
rm -f "$out"
# The Python client's codec (client/python): packed arrays against the repeated fields.
if [[ $filter == . || $filter == *ython* ]]; then
  bash client/python/install-venv.sh build/python-client-venv
  build/python-client-venv/bin/python tests/bench/python_codec_bench.py
fi
# The hostile family's service side is tools/run-hostile-benchmark.sh, not these e2e rows.
[[ ${1:-} != *Hostile* ]] || exit 0
mapfile -t e2e_points < <(grep -oE '[0-9]{4,}' <<<"${1:-}" || true)
e2e_threads=$(sed -nE 's|.*/[0-9]+/([0-9]+)\$?$|\1|p' <<<"${1:-}")
BUILD_DIR=build SKIP_BUILD=1 THREADS=${e2e_threads:-1 2} \
  bash tools/run-e2e-benchmark.sh --no-header "${e2e_points[@]}"
