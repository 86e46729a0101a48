#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# install-venv.sh VENV: the Python client installed as the README says, offline with Debian's
# packages: VENV made with --system-site-packages (python3-grpcio, -protobuf, -numpy), the wheel
# built with --no-index --no-build-isolation and installed into it. Built from a copy of
# client/python and proto/, so that a test leaves the checkout as it found it even when the build
# breaks; the copy is then checked for what setuptools would leave beside the sources (build/,
# *.egg-info: setup.py sends them to a scratch folder).
set -euo pipefail
# Only Debian's packages: no wheel folder or index that an environment or pip config may name.
unset PIP_FIND_LINKS PIP_INDEX_URL PIP_EXTRA_INDEX_URL
export PIP_CONFIG_FILE=/dev/null
root=$(cd "$(dirname "$0")/../.." && pwd)
venv=$1
stage=$(mktemp -d)
trap 'rm -rf "$stage"' EXIT
mkdir "$stage/client"
cp -r "$root/client/python" "$stage/client/python"
cp -r "$root/proto" "$stage/proto"
rm -rf "$stage/client/python/build" "$stage"/client/python/*.egg-info  # a local install's leftovers
rm -rf "$venv"
/usr/bin/python3 -m venv --system-site-packages "$venv"
"$venv/bin/pip" wheel --quiet --no-index --no-build-isolation --no-deps -w "$stage/dist" \
  "$stage/client/python"
"$venv/bin/pip" install --quiet --no-index "$stage"/dist/scanprep_client-*.whl
# setup.py builds in a scratch folder: the tree it was built from (here the copy) must be as it
# was, or `pip install ./client/python` would write build/ and *.egg-info into the checkout.
left=$(cd "$stage/client/python" && ls -d build *.egg-info 2>/dev/null || true)
if [[ -n $left ]]; then
  echo "install-venv.sh: building the wheel wrote into the source tree: $left" >&2
  exit 1
fi
