#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Configures and builds scanprep (Release) into ./build, or $BUILD_DIR: everything, tests and
# benchmarks included; with --service first, only scanprep-server and the scanprep CLI (the
# demo's build: a third of the targets, and no test packages needed). Other arguments go to cmake.
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir=${BUILD_DIR:-build}
targets=()
options=(-DSCANPREP_BUILD_TESTS=ON -DSCANPREP_BUILD_BENCHMARKS=ON)
if [[ ${1:-} == --service ]]; then
  shift
  targets=(scanprep-server scanprep)
  options=(-DSCANPREP_BUILD_TESTS=OFF -DSCANPREP_BUILD_BENCHMARKS=OFF)
fi
cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=Release "${options[@]}" "$@" >/dev/null
ninja -C "$build_dir" "${targets[@]}"
