#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The Node.js example (client/examples/node/process.js: the proto file, @grpc/grpc-js and
# ProcessUnary, no scanprep code) against a real scanprep-server: its plate's spike is removed.
# Usage: node_client_test.sh BUILD_DIR. Skips (77) without node or the example's packages
# (tools/install-deps.sh installs them), except under CI=true, where that fails.
set -euo pipefail
bin=$1
root=$(cd "$(dirname "$0")/.." && pwd)
example=$root/client/examples/node
if ! command -v node >/dev/null || [[ ! -d $example/node_modules/@grpc/grpc-js ]]; then
  echo "node or the example's packages (npm ci in $example) are missing"
  [[ ${CI:-} == true ]] && exit 1
  exit 77
fi
source "$root/tools/lib/local-server.sh"
log=$(mktemp)
trap 'kill "$server_pid" 2>/dev/null || true; rm -f "$log"' EXIT
start_local_server "$log"
out=$(node "$example/process.js" "127.0.0.1:$port")
stop_local_server
echo "$out"
[[ $out == "65 points sent, 64 returned" ]] || { echo "FAILED: expected the spike removed"; exit 1; }
