// SPDX-License-Identifier: Apache-2.0
// Empty: the one source of the test folders' precompiled-header targets (tests/CMakeLists.txt,
// scanprep_test_pch); CMake builds the header with this target's flags.
