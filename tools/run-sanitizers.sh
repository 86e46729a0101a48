#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The sanitizer jobs of CI (.ci/run), each in its own clang build directory:
#   asan  ASan + UBSan (+ libFuzzer coverage) on every target in ./build-asan; runs the C++
#         tests but the heaviest workloads (see below), then every fuzzer for FUZZ_SECONDS
#         (default 60) via tools/run-fuzzers.sh.
#   tsan  ThreadSanitizer in ./build-tsan; runs the server concurrency tests: concurrent jobs,
#         cancellations, deadlines, draining and shutdown (concurrency_test, faults_test,
#         admission_test, process_test).
# Usage: tools/run-sanitizers.sh [asan] [tsan]   (default: both). Any report fails the run.
set -euo pipefail
cd "$(dirname "$0")/.."
jobs=("$@")
((${#jobs[@]})) || jobs=(asan tsan)

bash tools/install-deps.sh --sanitizers  # the build's packages, clang and its runtimes

configure() {  # DIR, extra cmake flags...
  local dir=$1
  shift
  cmake -S . -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_COMPILER=clang++ \
    -DSCANPREP_BUILD_BENCHMARKS=OFF "$@" >/dev/null
}

for job in "${jobs[@]}"; do
  case $job in
    asan)
      configure build-asan -DSCANPREP_FUZZ=ON
      ninja -C build-asan
      # The C++ tests (googletest names hold a dot; the script checks run no sanitized code),
      # less the accuracy sweeps and throughput workloads whose code smaller tests run here too
      # (memory peaks mean nothing under ASan): they were half of this job's time.
      heavy='^(Metrology|MemoryPeak)\.|^Health\.(RotationAboutEachAxis|ShiftAlongEachAxis|ShiftOfSeveral|NoiseFollows)'
      heavy+='|^Cli\.ProgressOfAFourMillionPointJob|^SensorDrift\.ANoiseStepOverReplayedJobs'
      heavy+='|^Pipeline\.BunnyTenScans|^FullPipeline\.BunnyScannerSits|^Bunny\.TenScansRegister'
      heavy+='|^Outliers\.OverlappingScansLoseNoMore'
      # The two longest under ASan (124 s and 73 s): the TSan job runs the first's faults_test
      # whole, and the fuzzers run every reader the second reads the shared scans with.
      heavy+='|^Faults\.ClientsThatVanishMidUploadOrMidDownload|^Cli\.ProcessesEveryScanFileInTheSharedData'
      ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:strict_string_checks=1 \
      UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
        ctest --test-dir build-asan --output-on-failure -j "$(nproc)" -R '[.]' -E "$heavy"
      BUILD_DIR=build-asan bash tools/run-fuzzers.sh "${FUZZ_SECONDS:-60}"
      ;;
    tsan)
      tests=(concurrency_test faults_test admission_test process_test)
      configure build-tsan -DSCANPREP_SANITIZE=thread
      ninja -C build-tsan "${tests[@]}"
      TSAN_OPTIONS="halt_on_error=1:second_deadlock_stack=1:suppressions=$PWD/tests/tsan.supp" \
        ctest --test-dir build-tsan --output-on-failure -j "$(nproc)" \
        -R '^(Concurrency|Faults|AdmissionQueue|Admission|Process)\.'
      ;;
    *)
      echo "unknown job '$job' (asan or tsan)" >&2
      exit 2
      ;;
  esac
done
