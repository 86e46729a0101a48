# SPDX-License-Identifier: Apache-2.0
# Sourced by the service benchmarks (run-e2e-benchmark.sh, run-hostile-benchmark.sh): builds
# unless SKIP_BUILD=1, sets cli and bin for $BUILD_DIR (default build), loads local-server.sh,
# and makes a work directory that is removed, with any server still running, on exit.
build_dir=${BUILD_DIR:-build}
[[ ${SKIP_BUILD:-} == 1 ]] || bash tools/build.sh >/dev/null
cli=$build_dir/client/scanprep
bin=$build_dir  # for tools/lib/local-server.sh
source tools/lib/local-server.sh

work=$(mktemp -d)
server_pid=
cleanup() {
  # KILL: a server stuck in a case that overran is not waited for.
  if [[ -n $server_pid ]]; then kill -KILL "$server_pid" 2>/dev/null || true; fi
  rm -rf "$work"
}
trap cleanup EXIT
