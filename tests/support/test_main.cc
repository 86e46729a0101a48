// SPDX-License-Identifier: Apache-2.0
// The main of every test executable. CTest runs each test of a file as its own process, in
// parallel, so tests that write to ::testing::TempDir() under a fixed name would overwrite each
// other's files. Each process gets a scratch folder of its own instead (googletest's TempDir()
// reads TEST_TMPDIR), removed when the tests end; subprocesses the tests start inherit it.
#include <stdlib.h>

#include <filesystem>
#include <iostream>
#include <string>

#include <gtest/gtest.h>

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  const std::filesystem::path parent = std::filesystem::temp_directory_path();
  std::string scratch = (parent / "scanprep_test_XXXXXX").string();
  if (::mkdtemp(scratch.data()) == nullptr) {
    std::cerr << "cannot make a scratch folder under " << parent << "\n";
    return 2;
  }
  ::setenv("TEST_TMPDIR", scratch.c_str(), /*overwrite=*/1);
  const int result = RUN_ALL_TESTS();
  std::error_code ignored;
  std::filesystem::remove_all(scratch, ignored);
  return result;
}
