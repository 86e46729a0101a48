#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Fast proxy for the container build (tools/container-check.sh), run in CI: every shared library
# that ldd reports for the built binaries must come from a package the Dockerfile's runtime stage
# installs, or from one of their dependencies, or from an essential package of the base image.
# Usage: tools/check-runtime-libs.sh BINARY...
set -euo pipefail
cd "$(dirname "$0")/.."
(($#)) || { echo "usage: $0 BINARY..." >&2; exit 2; }

# The package list of the runtime stage: the apt-get install line after RUNTIME_PACKAGES.
mapfile -t runtime < <(awk '/RUNTIME_PACKAGES/ {grab=1} grab && /install/ {on=1} on {print} on && !/\\$/ {exit}' Dockerfile |
  tr ' \\' '\n\n' | grep -E '^lib[a-z0-9+.-]+$' | sort -u)
((${#runtime[@]})) || { echo "no runtime packages found in Dockerfile" >&2; exit 1; }

# What the runtime image has: those packages and everything they depend on, plus the
# Priority: required packages that debootstrap --variant=minbase installs.
provided=$(
  {
    printf '%s\n' "${runtime[@]}"
    apt-cache depends --recurse --no-recommends --no-suggests --no-conflicts --no-breaks \
      --no-replaces --no-enhances "${runtime[@]}" 2>/dev/null | grep -E '^[a-z0-9]' | sed 's/:.*//'
    dpkg-query -W -f='${Package} ${Priority}\n' | awk '$2 == "required" {print $1}'
  } | sed 's/:amd64$//' | sort -u)

# Every library the binaries load, once, with the package that owns it (one dpkg query for all;
# with merged /usr, dpkg may know a file under /lib rather than /usr/lib, so ask for both).
mapfile -t libs < <(for bin in "$@"; do ldd "$bin" | awk '/=>/ && $3 ~ /^\// {print $3}'; done |
  xargs -r readlink -f | sort -u)
declare -A owner=()
while IFS= read -r line; do
  file=${line#*: }
  owner["$file"]=${line%%:*}
  owner["/usr$file"]=${line%%:*}
done < <(dpkg -S "${libs[@]}" "${libs[@]#/usr}" 2>/dev/null)

status=0
for lib in "${libs[@]}"; do
  pkg=${owner[$lib]:-}
  if [[ -z "$pkg" ]]; then
    echo "MISSING  $lib belongs to no package"; status=1
  elif ! grep -qx "$pkg" <<<"$provided"; then
    echo "MISSING  $lib from $pkg, which the runtime stage does not install"; status=1
  fi
done
((status)) || echo "runtime-libs: the ${#libs[@]} libraries of $* all come from the runtime stage (${#runtime[@]} packages and their dependencies)"
exit $status
