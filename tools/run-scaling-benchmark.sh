#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Issue 31's many-core table: the bare nanoflann pass, the default pipeline and the preset `paper`
# on the 1 M benchmark cloud, and 4 M points at the 1 M density, at every thread count given,
# each case in its own process (tests/bench/pipeline_bench); then the speed-ups: the whole
# pipeline and every stage at N threads against 1, and 4 M against 1 M at the most threads.
# The run needs bash and coreutils only, so it works unchanged on a machine without the
# project's packages, with the bench binary from a bundle; the table is made where python3 is.
# Usage: tools/run-scaling-benchmark.sh [THREADS...]            (default: 1 2 4 8 16)
#        tools/run-scaling-benchmark.sh --table RESULTS.jsonl   (the table of a run made elsewhere)
# Environment: BENCH (default build/tests/bench/pipeline_bench; where the packages are missing,
# "bash .bundle/run pipeline_bench" after `bash ../shared/tools/portable-bundle.sh .bundle
# build/tests/bench/pipeline_bench` here), RESULTS (default scaling.jsonl: one line per case).
set -euo pipefail
cd "$(dirname "$0")/.."

table() {  # RESULTS.jsonl
  python3 - "$1" <<'PY'
import json, re, sys
rows, machine = {}, ""
for line in open(sys.argv[1]):
    doc = json.loads(line)
    if "machine" in doc:
        machine = f"{doc['machine']}, {doc['cores']} cores"
        continue
    for b in doc["benchmarks"]:
        case, points, threads = re.match(r"(?:BM_|RunPipelineCase/)(\w+)/(\d+)/(\d+)/", b["name"]).groups()
        rows[(case, int(points), int(threads))] = b
threads = sorted({t for (_, _, t) in rows})
top = threads[-1]
def sec(case, points, t):
    b = rows.get((case, points, t))
    return None if b is None else b["real_time"] / 1000.0
print(f"machine: {machine}\n")
print("| case | " + " | ".join(f"{t} thr (s)" for t in threads) + f" | {top} vs 1 |")
print("|---|" + "---:|" * (len(threads) + 1))
for case, points in [("BareNanoflannKnn", 1000000), ("DefaultPipeline", 1000000),
                     ("PaperPreset", 1000000), ("DefaultPipelinePartsInARow", 4000000)]:
    s = [sec(case, points, t) for t in threads]
    if all(v is None for v in s):
        continue
    cells = " | ".join("–" if v is None else f"{v:.3f}" for v in s)
    up = f"{s[0] / s[-1]:.1f}×" if s[0] and s[-1] else "–"
    print(f"| {case} {points:,} | {cells} | {up} |")
for case in ["DefaultPipeline", "PaperPreset"]:
    one, many = rows.get((case, 1000000, 1)), rows.get((case, 1000000, top))
    if not one or not many:
        continue
    print(f"\n{case}, 1 M, per stage (s): 1 thread → {top} threads, speed-up")
    for key in sorted(k for k in one if k.startswith("s_")):
        a, b = one[key], many.get(key, 0)
        print(f"- {key[2:]}: {a:.3f} → {b:.3f}, {a / b:.1f}×" if b else f"- {key[2:]}: {a:.3f} → –")
one, many = sec("DefaultPipeline", 1000000, 1), sec("DefaultPipeline", 1000000, top)
parts = sec("DefaultPipelinePartsInARow", 4000000, top)
if one and many:
    print(f"\ntarget: 1 M at {top} threads ≥ 13× the 1-thread time: {one / many:.1f}×")
if many and parts:
    print(f"target: 4 M at the 1 M density ≤ 4.4× the 1 M time at {top} threads: {parts / many:.2f}×")
PY
}

if [[ ${1:-} == --table ]]; then
  table "$2"
  exit 0
fi
threads=("$@")
((${#threads[@]})) || threads=(1 2 4 8 16)
read -ra bench <<<"${BENCH:-build/tests/bench/pipeline_bench}"
results=${RESULTS:-scaling.jsonl}
list=$(IFS=,; echo "${threads[*]}")
model=$(sed -n 's/^model name[[:space:]]*: //p' /proc/cpuinfo | head -1)
printf '{"machine": "%s", "cores": %s}\n' "${model//\"/}" "$(nproc)" >"$results"
filter='^(BM_BareNanoflannKnn|RunPipelineCase/(DefaultPipeline|PaperPreset))/1000000/|^RunPipelineCase/DefaultPipelinePartsInARow/'
mapfile -t cases < <(SCANPREP_BENCH_THREADS=$list "${bench[@]}" --benchmark_list_tests \
  --benchmark_filter="$filter")
for c in "${cases[@]}"; do
  echo "$c" >&2
  # One line per case: the JSON document with its line breaks removed.
  SCANPREP_BENCH_THREADS=$list "${bench[@]}" --benchmark_filter="^${c}\$" \
    --benchmark_format=json 2>/dev/null | tr -d '\n' >>"$results"
  echo >>"$results"
done
if command -v python3 >/dev/null; then
  table "$results"
else
  echo "no python3 here: make the table with tools/run-scaling-benchmark.sh --table $results" >&2
fi
