#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Every C++ file as clang-format (.clang-format: Google style, 100 columns) would write it; lists
# the files that differ (--self-test: shows that a misformatted line fails).
# Fix with: clang-format -i $(git ls-files "*.cc" "*.h")
set -euo pipefail
cd "$(dirname "$0")/.."
if [[ ${1:-} == --self-test ]]; then  # the check can fail: a misformatted line must be caught
  if printf 'int  f( ){return 1 ;}\n' | clang-format --dry-run --Werror --assume-filename=x.cc \
       >/dev/null 2>&1; then
    echo "self-test: clang-format accepted a misformatted line" >&2
    exit 1
  fi
  echo "self-test: a misformatted line is caught"
  exit 0
fi
mapfile -t files < <(git ls-files '*.cc' '*.h' 2>/dev/null || find core server client proto tests \( -name '*.cc' -o -name '*.h' \))
((${#files[@]})) || { echo "no C++ files found" >&2; exit 1; }
bad=()
for f in "${files[@]}"; do
  clang-format --dry-run --Werror "$f" >/dev/null 2>&1 || bad+=("$f")
done
if ((${#bad[@]})); then
  printf 'not clang-formatted: %s\n' "${bad[@]}" >&2
  exit 1
fi
echo "${#files[@]} files formatted"
