#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Builds the libFuzzer targets (tests/fuzz, ASan + UBSan, clang) into ./build-asan, or $BUILD_DIR,
# and runs each for SECONDS (default 60) over a scratch copy of its seed corpus. Prints runs,
# coverage and the result per target; exits non-zero if any target crashed, leaked, hung or ran
# out of memory (the reproducer is kept and its path printed).
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-60}
build_dir=${BUILD_DIR:-build-asan}
targets=(ply_fuzzer xyz_fuzzer pcd_fuzzer e57_fuzzer las_fuzzer conf_fuzzer job_file_fuzzer assembler_fuzzer service_fuzzer)

bash tools/install-deps.sh --sanitizers
# The same configuration as tools/run-sanitizers.sh, so both can share one build directory.
cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_COMPILER=clang++ \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -gline-tables-only -DNDEBUG" \
  -DSCANPREP_FUZZ=ON -DSCANPREP_BUILD_BENCHMARKS=OFF >/dev/null
ninja -C "$build_dir" "${targets[@]}"

work=$(mktemp -d "${TMPDIR:-/tmp}/scanprep-fuzz.XXXXXX")
failed=0
printf '%-18s %10s %8s %8s  %s\n' target runs cov ft result
for t in "${targets[@]}"; do
  mkdir -p "$work/$t/corpus" "$work/$t/artifacts"
  cp tests/fuzz/corpus/"$t"/* "$work/$t/corpus/"
  status=0
  "$build_dir/tests/fuzz/$t" "$work/$t/corpus" -max_total_time="$seconds" -rss_limit_mb=2048 \
    -timeout=10 -print_final_stats=1 -artifact_prefix="$work/$t/artifacts/" \
    >"$work/$t/log" 2>&1 || status=$?
  runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$work/$t/log")
  last=$(grep -E '^#[0-9]+[[:space:]].*cov: ' "$work/$t/log" | tail -1 || true)
  cov=$(sed -n 's/.* cov: \([0-9]*\).*/\1/p' <<<"$last")
  ft=$(sed -n 's/.* ft: \([0-9]*\).*/\1/p' <<<"$last")
  if [[ $status -eq 0 ]]; then
    result=ok
  else
    failed=1
    result="FAILED (exit $status): $(grep -m1 -E '^(==[0-9]+==ERROR|SUMMARY|fuzz invariant)' "$work/$t/log" || true)"
    result+=" reproducer: $(ls "$work/$t/artifacts"/* 2>/dev/null | head -1) log: $work/$t/log"
  fi
  printf '%-18s %10s %8s %8s  %s\n' "$t" "${runs:-?}" "${cov:-?}" "${ft:-?}" "$result"
done
if [[ $failed -eq 0 ]]; then rm -rf "$work"; fi
exit $failed
