#!/usr/bin/env bash
# Fast proxy for the container build (deploy/container-check.sh), run in CI: every shared library
# that ldd reports for the built binaries must come from a package the Dockerfile's runtime stage
# installs, or from one of their dependencies, or from an essential package of the base image.
# Usage: deploy/check-runtime-libs.sh BINARY...
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

status=0
for bin in "$@"; do
  while read -r lib path; do
    [[ -n "$path" ]] || continue
    real=$(readlink -f "$path")
    pkg=$(dpkg -S "$real" 2>/dev/null | head -1 | cut -d: -f1) || true
    [[ -n "$pkg" ]] || pkg=$(dpkg -S "$path" 2>/dev/null | head -1 | cut -d: -f1) || true
    if [[ -z "$pkg" ]]; then
      echo "MISSING  $bin: $lib ($path) belongs to no package"; status=1
    elif ! grep -qx "$pkg" <<<"$provided"; then
      echo "MISSING  $bin: $lib from $pkg, which the runtime stage does not install"; status=1
    fi
  done < <(ldd "$bin" | awk '/=>/ && $3 ~ /^\// {print $1, $3}')
done
((status)) || echo "runtime-libs: every library of $* is provided by the runtime stage (${#runtime[@]} packages)"
exit $status
