#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The main job: installs what is missing, builds the server and the CLI (Release), starts scanprep-server on loopback,
# processes a sample scan through the default pipeline, prints the report, draws the input and
# the result side by side as PNG ($PREVIEW, default build/bunny-preview.png), stops the server.
# The sample is two overlapping Stanford bunny scans from ../shared/data when present, else a
# scan the project generates (`scanprep simulate`).
set -euo pipefail
cd "$(dirname "$0")/.."
# Only what the demo runs: the server and the CLI (the test command builds and installs the rest).
bash tools/install-deps.sh --build-only
bash tools/build.sh --service
bin=${BUILD_DIR:-build}
out=$(mktemp -d)
trap 'kill "$server_pid" 2>/dev/null || true; wait 2>/dev/null || true; rm -rf "$out"' EXIT

# Plaintext on loopback for the demo; a deployment gives --tls_cert/--tls_key/--tls_client_ca.
source tools/lib/local-server.sh
start_local_server "$out/server.log"
echo "scanprep-server listening on 127.0.0.1:$port"

data=../shared/data/stanford_bunny_range_scans
if [[ -d "$data" ]]; then
  preview=${PREVIEW:-$bin/bunny-preview.png}
  "$bin/client/scanprep" process "$data/bun000.ply" "$data/bun045.ply" --conf "$data/bun.conf" \
    --job client/examples/bunny.job.json --server "127.0.0.1:$port" -o "$out/bunny.ply" \
    --preview "$preview"
  echo "the input and the result side by side: $preview (docs/images/bunny-preview.png is one)"
else
  echo "../shared/data not found: processing a generated scan instead"
  "$bin/client/scanprep" simulate --points 200000 -o "$out/sample.ply"
  "$bin/client/scanprep" process "$out/sample.ply" --job "$out/sample.job.json" \
    --server "127.0.0.1:$port" -o "$out/sample-processed.ply"
fi
stop_local_server
echo "server stopped"
