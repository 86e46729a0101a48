#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# buf lint of the API (proto/buf.yaml: STANDARD rules but the service-name suffix). buf is not
# packaged in Debian: it comes from npm (@bufbuild/buf ships the binary), pinned, into a cache
# directory outside the tree ($BUF_DIR, default ~/.cache/scanprep-buf).
set -euo pipefail
cd "$(dirname "$0")/.."
version=1.75.0
dir=${BUF_DIR:-$HOME/.cache/scanprep-buf}
if ! command -v npm >/dev/null; then
  sudo_cmd=()
  [[ $(id -u) -eq 0 ]] || sudo_cmd=(sudo)
  "${sudo_cmd[@]}" apt-get update -qq
  DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends npm
fi
buf=$dir/node_modules/.bin/buf
if [[ ! -x $buf ]] || [[ $("$buf" --version) != "$version" ]]; then
  mkdir -p "$dir"
  npm install --prefix "$dir" --no-save --no-audit --no-fund --loglevel=error \
    "@bufbuild/buf@$version"
fi
(cd proto && "$buf" lint)
echo "buf lint $version: proto/ clean"
