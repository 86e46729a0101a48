#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# install-venv.sh VENV: the Python client installed as the README says, offline with Debian's
# packages: VENV made with --system-site-packages (python3-grpcio, -protobuf, -numpy), the wheel
# built with --no-index --no-build-isolation and installed into it. Built from a copy of
# client/python and proto/, because setuptools writes build/ and *.egg-info beside the sources it
# builds, and a test must leave the checkout as it found it.
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
