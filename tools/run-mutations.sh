#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The mutation check, run by CI (.ci/run): breaks each equation and guard of the stages listed in
# tools/mutations.txt one at a time, rebuilds the core test executables and requires the core
# test suite to FAIL on every mutation. A mutation the suite survives means a test is missing.
#
# Each mutation replaces one exact snippet of one file. The snippet must occur exactly once: a
# refactor that moves or rewrites it fails this check loudly instead of turning the mutation
# into a silent no-op. A mutation that does not compile is an error in the list, not a kill.
# Every mutated file is restored on exit, however the run ends (trap), and the run fails if the
# tree then differs from what it was at the start.
#
# Usage: tools/run-mutations.sh [NAME_REGEX]   (default: every mutation)
# Environment: BUILD_DIR (default build; reused, configured Release if new), MUTATION_TIMEOUT
# (seconds for one mutation's test run, default 300; a hang counts as a kill), MUTATION_BASELINE
# (0: skip the unmutated suite's run, for a build whose suite has just passed), MUTATION_BUDGET
# (seconds; default none: every selected mutation runs), MUTATION_TARGETS (the executables the
# baseline and the closing build make; default the core suite's: a run of server mutations that
# name their tests needs only those, with MUTATION_BASELINE=0).
#
# With a budget (CI's, .ci/run: the whole list takes about 30 minutes on two cores, more than CI
# can give it) the mutations run in an order that puts first what a change can have broken, and
# no new one starts once the budget is spent; the table then lists the ones not run. The order:
# mutations of files that the last MUTATION_RECENT commits (default 40, about one stop's work)
# changed, then the rest shuffled by the commit (a hash of the name and HEAD), so successive
# commits reach different ones. A budgeted run is a sample: the whole list is run before a stop.
set -euo pipefail
cd "$(dirname "$0")/.."
source tools/lib/test-suites.sh
build_dir=${BUILD_DIR:-build}
list=tools/mutations.txt
filter=${1:-.}
timeout_s=${MUTATION_TIMEOUT:-300}
work=$(mktemp -d)
tree_before=$(git diff HEAD | sha1sum)

# Restores every file a mutation touched from its saved copy; cp, not git, so uncommitted work
# in those files survives too. Not cp -p: the restored file must be newer than the mutated
# objects, or ninja keeps them and the mutation lives on into the next runs.
restore() {
  local saved
  for saved in "$work"/saved/*; do
    [[ -e $saved ]] || continue
    cp "$saved" "$(cat "$saved.path")"
    rm -f "$saved" "$saved.path"
  done
}
trap 'restore; rm -rf "$work"' EXIT
trap 'exit 130' INT TERM

# The list: blocks of "name = …", "what = …", "file = …", "from = …", "to = …" lines; # comments.
mutations() {  # prints the selected names, one a line, in the order they run
  local recent=() head
  if [[ -n ${MUTATION_BUDGET:-} ]]; then
    head=$(git rev-parse HEAD)
    mapfile -t recent < <(git log -n "${MUTATION_RECENT:-40}" --format= --name-only | sort -u)
  fi
  python3 - "$list" "$filter" "${head:-}" "${recent[@]}" <<'PY'
import hashlib, re, sys
text = open(sys.argv[1]).read()
names = re.findall(r"^name\s*=\s*(\S+)", text, re.M)
if len(names) != len(set(names)):
    sys.exit("mutations.txt: duplicate names")
files = dict(re.findall(r"^name\s*=\s*(\S+)\n(?:.*\n)*?file\s*=\s*(\S+)", text, re.M))
names = [n for n in names if re.search(sys.argv[2], n)]
head, recent = sys.argv[3], set(sys.argv[4:])
if head:  # a budget: what the recent commits touched first, the rest in this commit's order
    names.sort(key=lambda n: (files.get(n) not in recent,
                              hashlib.sha1((head + n).encode()).hexdigest()))
print("\n".join(names))
PY
}

# Saves the file of mutation NAME into $work/saved, writes the mutated file, prints its "what".
apply_mutation() {
  python3 - "$list" "$1" "$work/saved" <<'PY'
import os, re, shutil, sys
blocks = [b for b in re.split(r"\n\s*\n", open(sys.argv[1]).read())]
fields = None
for block in blocks:
    f = dict(re.findall(r"^(name|what|file|from|to|tests)\s*=\s?(.*)$", block, re.M))
    if f.get("name") == sys.argv[2]:
        fields = f
missing = {"name", "what", "file", "from", "to"} - set(fields or {})
if missing:
    sys.exit(f"mutation {sys.argv[2]}: missing {sorted(missing)}")
path, old, new = fields["file"], fields["from"].strip(), fields["to"].strip()
text = open(path).read()
count = text.count(old)
if count != 1:
    sys.exit(f"mutation {sys.argv[2]}: the snippet occurs {count} times in {path}, not once "
             f"(was the code changed? update tools/mutations.txt):\n  {old}")
os.makedirs(sys.argv[3], exist_ok=True)
saved = os.path.join(sys.argv[3], path.replace("/", "+"))
shutil.copy2(path, saved)
open(saved + ".path", "w").write(path)
open(path, "w").write(text.replace(old, new))
open(os.path.join(sys.argv[3], "..", "tests"), "w").write(fields.get("tests", "").strip())
print(fields["what"])
PY
}

# The suite: every test of tests/core except the readers' (tests/core/io/io_*), which no mutation
# touches; io's fuzz regressions stay in.
mapfile -t sources < <(ls tests/core/*/*_test.cc | grep -v '/io_')
targets=()
for s in "${sources[@]}"; do targets+=("$(basename "$s" .cc)"); done
suite_regex=$(test_suite_regex "${sources[@]}")

[[ -f $build_dir/build.ninja ]] ||
  cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
if [[ -n ${MUTATION_TARGETS:-} ]]; then read -ra targets <<<"$MUTATION_TARGETS"; fi
build() { ninja -C "$build_dir" "${targets[@]}" >"$work/build.log" 2>&1; }
# A mutation naming the executables that kill it builds and runs only those (a whole-suite
# relink per mutation would cost CI most of its budget); its first failing test is the killer.
run_named() {  # EXECUTABLES...; the first failing test's name on stdout; status 0 if all passed
  local exe rc=0
  for exe in "$@"; do
    # Fail fast: one failing test is the kill, and a mutation that makes the later tests of the
    # executable slow (an approximate tree, a lost bound) would otherwise cost minutes each.
    timeout -k 10 "$timeout_s" "$build_dir/tests/$exe" --gtest_fail_fast >"$work/gtest.log" 2>&1 || rc=$?
    ((rc == 124 || rc == 137)) && { echo "$exe (timeout after ${timeout_s} s)"; return 1; }
    if ((rc != 0)); then
      grep -m1 -oE '^\[  FAILED  \] [^ ]+' "$work/gtest.log" | sed 's/^\[  FAILED  \] //' || echo "$exe"
      return "$rc"
    fi
  done
}
run_suite() {  # the first failing test's name on stdout; status 0 if every test passed
  local rc=0
  timeout -k 10 "$timeout_s" ctest --test-dir "$build_dir" -R "$suite_regex" -j "$(nproc)" \
    --stop-on-failure >"$work/ctest.log" 2>&1 || rc=$?
  ((rc == 124 || rc == 137)) && { echo "(timeout after ${timeout_s} s)"; return 1; }
  grep -m1 -oE 'Test +#[0-9]+: [^ ]+ \.*\*\*\*[A-Za-z]+' "$work/ctest.log" |
    sed -E 's/Test +#[0-9]+: ([^ ]+) \.*\*\*\*(.*)/\1 (\2)/' || true
  return "$rc"
}

mapfile -t names < <(mutations)
((${#names[@]})) || { echo "no mutation matches '$filter'" >&2; exit 2; }
start=$SECONDS
echo "baseline: building ${#targets[@]} test executables, then the unmutated suite (MUTATION_BASELINE=${MUTATION_BASELINE:-1})"
build || { cat "$work/build.log"; echo "the unmutated tree does not build" >&2; exit 1; }
# CI sets MUTATION_BASELINE=0: tools/run-tests.sh has just run the whole suite on this build.
if [[ ${MUTATION_BASELINE:-1} != 0 ]] && ! run_suite >/dev/null; then
  cat "$work/ctest.log"
  echo "the unmutated suite fails: no mutation can be judged" >&2
  exit 1
fi

rows=() survived=0 broken=0 skipped=()
for name in "${names[@]}"; do
  t0=$SECONDS
  if [[ -n ${MUTATION_BUDGET:-} ]] && ((t0 - start >= MUTATION_BUDGET)); then
    skipped+=("$name")
    continue
  fi
  if ! what=$(apply_mutation "$name"); then
    rows+=("| $name | (the list is stale: see above) | ERROR | | 0 |")
    broken=$((broken + 1))
    continue
  fi
  read -ra named <"$work/tests" || true
  if ! { if ((${#named[@]})); then ninja -C "$build_dir" "${named[@]}" >"$work/build.log" 2>&1;
         else build; fi; }; then
    grep -m3 -E 'error' "$work/build.log" >&2 || true
    verdict="ERROR: does not compile" killer=
    broken=$((broken + 1))
  elif killer=$(if ((${#named[@]})); then run_named "${named[@]}"; else run_suite; fi); then
    verdict=SURVIVED killer=
    survived=$((survived + 1))
  else
    verdict=killed
  fi
  restore
  rows+=("| $name | $what | $verdict | ${killer:-} | $((SECONDS - t0)) |")
  printf '%-40s %-9s %s (%d s)\n' "$name" "$verdict" "${killer:-}" "$((SECONDS - t0))" >&2
done

# Leave the build matching the restored tree, so the next ctest run tests the real code.
build || { cat "$work/build.log"; exit 1; }
echo
echo "| mutation | what it breaks | verdict | killed by | seconds |"
echo "|---|---|---|---|---:|"
printf '%s\n' "${rows[@]}"
echo
ran=$((${#names[@]} - ${#skipped[@]}))
echo "$ran mutations: $((ran - survived - broken)) killed, $survived survived," \
  "$broken broken; $((SECONDS - start)) s in all on $(nproc) cores"
if ((${#skipped[@]})); then
  echo "not run within the ${MUTATION_BUDGET} s budget (${#skipped[@]} of ${#names[@]}): ${skipped[*]}"
fi
if [[ $(git diff HEAD | sha1sum) != "$tree_before" ]]; then
  git diff --stat HEAD
  echo "the tree differs from before the run: a mutation was not restored" >&2
  exit 1
fi
((survived == 0 && broken == 0))
