#!/usr/bin/env bash
# The main job: installs what is missing, builds Release, starts scanprep-server on loopback,
# processes a sample scan through the default pipeline, prints the report, stops the server.
# The sample is two overlapping Stanford bunny scans from ../shared/data when present, else a
# scan the project generates (`scanprep simulate`).
set -euo pipefail
cd "$(dirname "$0")/.."
bash deploy/install-deps.sh
bash deploy/build.sh
bin=${BUILD_DIR:-build}
out=$(mktemp -d)
trap 'kill "$server_pid" 2>/dev/null || true; wait 2>/dev/null || true; rm -rf "$out"' EXIT

# Plaintext on loopback for the demo; a deployment gives --tls_cert/--tls_key/--tls_client_ca.
"$bin/server/scanprep-server" --plaintext --listen=127.0.0.1:0 >"$out/server.log" 2>&1 &
server_pid=$!
for _ in $(seq 100); do
  port=$(sed -n 's/.*listening on port \([0-9]*\).*/\1/p' "$out/server.log")
  [[ -n "$port" ]] && break
  sleep 0.1
done
[[ -n "${port:-}" ]] || { cat "$out/server.log"; echo "server did not start" >&2; exit 1; }
echo "scanprep-server listening on 127.0.0.1:$port"

data=../shared/data/stanford_bunny_range_scans
if [[ -d "$data" ]]; then
  "$bin/client/scanprep" process "$data/bun000.ply" "$data/bun045.ply" --conf "$data/bun.conf" \
    --job deploy/examples/bunny.job.json --server "127.0.0.1:$port" -o "$out/bunny.ply"
else
  echo "../shared/data not found: processing a generated scan instead"
  "$bin/client/scanprep" simulate --points 200000 -o "$out/sample.ply"
  "$bin/client/scanprep" process "$out/sample.ply" --job "$out/sample.job.json" \
    --server "127.0.0.1:$port" -o "$out/sample-processed.ply"
fi
kill -TERM "$server_pid"
wait "$server_pid"
echo "server stopped"
