#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The sanitizer jobs, each in its own clang build directory:
#   asan        ASan + UBSan (+ libFuzzer coverage) on every target in ./build-asan; runs the C++
#               tests but the heaviest workloads (see below), then every fuzzer for FUZZ_SECONDS
#               (default 60) via tools/run-fuzzers.sh. About 45 minutes on two cores.
#   asan-quick  the same build directory, only the fuzzers and the core tests of the layers that
#               index memory from the data (base, spatial, io, sim: the cell grid and k-NN lists,
#               every reader, the fuzz regressions); runs those tests, then every fuzzer for
#               FUZZ_SECONDS. The fuzzers run the stages (the assembler's on every small job it
#               accepts) and the whole service under ASan. About 15 minutes.
#   tsan        ThreadSanitizer in ./build-tsan; runs the server concurrency tests: concurrent
#               jobs, cancellations, deadlines, draining and shutdown (concurrency_test,
#               faults_test, admission_test, process_test). About 15 minutes.
# CI (.ci/run) runs asan-quick or tsan, chosen by its commit: the three
# together take longer than CI's whole budget. All three are run before a stop.
# Usage: tools/run-sanitizers.sh [asan] [asan-quick] [tsan]   (default: asan and tsan). Any
# report fails the run.
set -euo pipefail
cd "$(dirname "$0")/.."
source tools/lib/test-suites.sh
jobs=("$@")
((${#jobs[@]})) || jobs=(asan tsan)

bash tools/install-deps.sh --sanitizers  # the build's packages, clang and its runtimes

# -O1 with line tables only: what an ASan or UBSan report needs (function, file, line), at about
# half the compile time of RelWithDebInfo's -O2 -g. The TSan build adds -g back (CMakeLists.txt):
# its suppressions match qualified names, which line tables drop from inlined frames.
configure() {  # DIR, extra cmake flags...
  local dir=$1
  shift
  cmake -S . -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_COMPILER=clang++ \
    -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -gline-tables-only -DNDEBUG" \
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
      heavy+='|^Cli\.ProgressOfAMultiMillionPointJob|^SensorDrift\.ANoiseStepOverReplayedJobs'
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
    asan-quick)
      configure build-asan -DSCANPREP_FUZZ=ON
      mapfile -t tests < <(ls tests/core/{base,spatial,io,sim}/*_test.cc | xargs -n1 basename |
        sed 's/[.]cc$//')
      ninja -C build-asan "${tests[@]}"
      suites=$(test_suite_regex tests/core/{base,spatial,io,sim}/*_test.cc)
      ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:strict_string_checks=1 \
      UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
        ctest --test-dir build-asan --output-on-failure -j "$(nproc)" -R "$suites"
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
      echo "unknown job '$job' (asan, asan-quick or tsan)" >&2
      exit 2
      ;;
  esac
done
