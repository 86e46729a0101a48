#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Configures and builds scanprep (Release) into ./build, or $BUILD_DIR.
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir=${BUILD_DIR:-build}
cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=Release "$@" >/dev/null
ninja -C "$build_dir"
