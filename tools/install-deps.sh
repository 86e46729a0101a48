#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Installs the Debian 12 packages scanprep builds and tests with. Safe to repeat: apt runs only
# when something is missing. With --sanitizers also clang and its sanitizer and libFuzzer runtimes
# (tools/run-sanitizers.sh, tools/run-fuzzers.sh); with --build-only just what scanprep-server and
# the scanprep CLI build with (tools/run-demo.sh).
set -euo pipefail

# What the server and the CLI build with (the demo's --build-only), then what the tests,
# benchmarks and checks add.
packages=(
  cmake ninja-build g++ pkg-config
  libgrpc++-dev protobuf-compiler-grpc libprotobuf-dev libabsl-dev
  libeigen3-dev libnanoflann-dev libtbb-dev libcpp-httplib-dev
  liblzf-dev  # PCD DATA binary_compressed (core/io/pcd.cc)
  libcli11-dev  # the CLI's flags (client/cli_args.cc)
  libexpat1-dev  # the XML section of E57 files (core/io/e57_xml.cc)
  libpng-dev  # preview pictures (client/preview.cc)
  zlib1g-dev  # CRC-32 of the StreamEnd (wire/stream_checksum.cc)
)
if [[ ${1:-} != --build-only ]]; then
  packages+=(
    libgtest-dev libgmock-dev libbenchmark-dev
    prometheus  # prometheus and promtool: alert-rule and integration tests
    openssl     # tls_test makes its certificates at test time
    clang-format  # the clang_format test (tools/check-format.sh)
    python3-grpcio python3-protobuf python3-numpy  # client/python and its tests (python_client*)
    python3-venv python3-pip python3-setuptools python3-wheel  # its wheel, built and installed offline
    python3-yaml  # tools/check_manifests.py (kubernetes_manifests test)
    dpkg-dev  # dpkg-shlibdeps: the .deb's Depends (cpack, tools/check-package.sh)
  )
  # Node.js and npm for the second-language example (client/examples/node, node_client_example),
  # Debian's unless the machine has its own node with npm.
  command -v npm >/dev/null || packages+=(nodejs npm)
fi
if [[ ${1:-} == --sanitizers ]]; then
  packages+=(clang libclang-rt-14-dev)
fi

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "installing: ${missing[*]}"
  sudo_cmd=()
  [[ $(id -u) -eq 0 ]] || sudo_cmd=(sudo)
  "${sudo_cmd[@]}" apt-get update -qq
  DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
# The Node example's two packages (@grpc/grpc-js, @grpc/proto-loader) from the npm registry, at
# the versions its lock file names.
node_example=$(dirname "$0")/../client/examples/node
if [[ ${1:-} != --build-only && ! -d $node_example/node_modules/@grpc/grpc-js ]]; then
  (cd "$node_example" && npm ci --no-audit --no-fund --loglevel=error)
fi
