# SPDX-License-Identifier: Apache-2.0
# Sourced by the tools scripts that need a local server: start_local_server LOG [FLAGS...] runs
# $bin/server/scanprep-server (or the command in the array server_cmd, e.g. a bundle's launcher,
# which must exec the server so that $! is its pid) in plaintext on a free loopback port and sets
# server_pid and port; stop_local_server sends SIGTERM and returns the server's exit status. With PIN=CPUS set the
# server runs on those CPUs only (taskset).
start_local_server() {
  local log=$1
  shift
  : >"$log"  # a previous server's "listening on port" must not be read as this one's
  # Metrics on a free loopback port, so that another server on this host (its default 9464)
  # cannot make this one fail to start; FLAGS may override it.
  ${PIN:+taskset -c "$PIN"} "${server_cmd[@]:-$bin/server/scanprep-server}" --plaintext --listen=127.0.0.1:0 --metrics_listen=127.0.0.1:0 \
    "$@" \
    >"$log" 2>&1 &
  server_pid=$!
  port=
  for _ in $(seq 100); do
    port=$(sed -n 's/.*listening on port \([0-9]*\).*/\1/p' "$log")
    [[ -n "$port" ]] && return 0
    sleep 0.1
  done
  cat "$log" >&2
  echo "scanprep-server did not start" >&2
  return 1
}

stop_local_server() {
  kill -TERM "$server_pid"
  wait "$server_pid"
}
