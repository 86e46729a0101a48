#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Behaviour unchanged? Runs a fixed set of jobs (simulated, and the real scans of ../shared/data
# where present) through a local server and prints one line per job: the SHA-256 of its result
# file and of its report's parameters and counts (the timings left out). Run it on two builds and
# diff the outputs: a refactor must leave every line the same.
#
# Usage: tools/hash-outputs.sh [BIN_DIR]   (BIN_DIR holds server/scanprep-server and
# client/scanprep, default build; or a folder holding both binaries directly)
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${1:-build}
server_bin=$bin/server/scanprep-server client_bin=$bin/client/scanprep
[[ -x $server_bin ]] || server_bin=$bin/scanprep-server client_bin=$bin/scanprep
work=$(mktemp -d)
trap 'kill "$server_pid" 2>/dev/null || true; rm -rf "$work"' EXIT
"$server_bin" --plaintext --listen=127.0.0.1:0 --metrics_listen=127.0.0.1:0 >"$work/server.log" 2>&1 &
server_pid=$!
port=
for _ in $(seq 100); do
  port=$(sed -n 's/.*listening on port \([0-9]*\).*/\1/p' "$work/server.log")
  [[ -n $port ]] && break
  sleep 0.1
done
[[ -n $port ]] || { cat "$work/server.log" >&2; exit 1; }

# One job: NAME, then the arguments of `scanprep process` after its inputs' paths.
job() {
  local name=$1
  shift
  "$client_bin" process "$@" --server "127.0.0.1:$port" --include_removed \
    -o "$work/$name.ply" --report_json "$work/$name.json" >"$work/$name.log" 2>&1 ||
    { cat "$work/$name.log" >&2; return 1; }
  # The report without its clocks: what was computed, not how long it took.
  local report
  report=$(python3 -c '
import json, sys
def strip(v):
    if isinstance(v, dict):
        return {k: strip(x) for k, x in v.items() if "second" not in k and k not in ("phases", "budget_met", "started", "finished")}
    if isinstance(v, list):
        return [strip(x) for x in v]
    return v
print(json.dumps(strip(json.load(open(sys.argv[1]))), sort_keys=True))' "$work/$name.json" | sha256sum)
  echo "$name result $(sha256sum <"$work/$name.ply" | cut -c1-16) report ${report:0:16}"
}

"$client_bin" simulate --points 200000 --scans 2 --seed 7 -o "$work/sim.ply" >/dev/null
sims=("$work"/sim_*.ply)
job sim-default "${sims[@]}" --job "$work/sim.job.json"
job sim-paper "${sims[@]}" --job "$work/sim.job.json" --preset paper
job sim-loop "${sims[@]}" --job "$work/sim.job.json" --param outliers.method=loop \
  --param normals.radius_mode=mitra --param smoothing.iterations=2 --param correction.mode=scatter
job sim-health "${sims[@]}" --job "$work/sim.job.json" --stages health

data=../shared/data
if [[ -d $data ]]; then
  bunny=$data/stanford_bunny_range_scans
  job bunny "$bunny/bun000.ply" "$bunny/bun045.ply" --conf "$bunny/bun.conf" \
    --job client/examples/bunny.job.json
  buddha=$data/stanford_happy_stand_range_scans
  job buddha "$buddha"/happyStandRight_{264,288,312,336,24}.ply --conf "$buddha/happyStandRight.conf" \
    --job client/examples/happy_buddha.job.json
  job rs1 "$data/pcl_rs1_laser_scene/rs1.pcd" --unit m
  job mug "$data/pcl_table_scene_mug_stereo/table_scene_mug_stereo_textured.pcd" --unit m
  job cognex "$data/cognex_laser_line_scan/triangulated.xyz" --unit mm
  job e57 "$data/e57_bunny_sample/bunnyDouble.e57" --unit m
else
  echo "../shared/data not found: real scans skipped" >&2
fi
