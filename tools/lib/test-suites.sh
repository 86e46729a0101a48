# SPDX-License-Identifier: Apache-2.0
# Sourced by the tools scripts that run the tests of some source files alone: test_suite_regex
# FILE... prints a ctest -R pattern matching every test of the gtest suites those files define
# (TEST, TEST_F and TEST_P), e.g. ^(Correction|Smoothing)[.]
test_suite_regex() {
  local suites
  suites=$(grep -ohE '^TEST(_F|_P)?\(\w+' "$@" | sed 's/.*(//' | sort -u | paste -sd'|')
  echo "^($suites)[.]"
}
