#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Issue 39's contention classes through a fresh local scanprep-server each (default flags, 2
# threads; docs/hostile-inputs.md "Contention"): an ordinary job's latency alone and beside four
# slow legal uploads (20 M points declared each, 70 kB/s), with what they hold; then how long a
# second client host's job waits for its slot while another host resubmits 12 calls at once (two
# slots; the hosts told apart by x-forwarded-for from a trusted loopback proxy). Prints a
# markdown table.
# Usage: tools/run-contention-probe.sh [POINTS]   (default 100000 points per ordinary job)
# Environment: BUILD_DIR (default build); PYTHON (default the Python client's venv that ctest's
# python_client_install makes, BUILD_DIR/tests/python-client-venv/bin/python).
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${BUILD_DIR:-build}
python=${PYTHON:-$bin/tests/python-client-venv/bin/python}
points=${1:-100000}
source tools/lib/local-server.sh
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# CASE [SERVER FLAGS...]: one case against its own server.
probe() {
  local case=$1
  shift
  start_local_server "$work/$case.log" --threads=2 "$@"
  local metrics
  metrics=$(sed -n 's/.*metrics on port \([0-9]*\).*/\1/p' "$work/$case.log")
  "$python" tools/lib/contention_probe.py "$case" "127.0.0.1:$port" "$metrics" "$points"
  stop_local_server || true
}

echo "| case | ordinary job | held meanwhile |"
echo "|---|---|---|"
probe slow_uploads
# As many slots as arena threads: with more, a job granted a slot waits in the arena's own queue
# behind the jobs granted before it, and a slot's time is no longer a job's.
probe host_flood --trusted_proxies=127.0.0.1/32 --max_concurrent_jobs=2
