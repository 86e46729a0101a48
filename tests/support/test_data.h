// Locates the real scans in ../shared/data; tests that need them skip when it is absent.
#pragma once

#include <filesystem>
#include <string>

#include <gtest/gtest.h>

namespace scanprep::testing {

// The shared data folder (override with SCANPREP_DATA_DIR), or empty when it does not exist.
std::filesystem::path SharedDataDir();

}  // namespace scanprep::testing

// Skips the current test with a clear message when ../shared/data is missing.
#define SCANPREP_REQUIRE_SHARED_DATA(dir_var)                                               \
  const std::filesystem::path dir_var = ::scanprep::testing::SharedDataDir();                \
  if (dir_var.empty()) {                                                                     \
    GTEST_SKIP() << "real-scan data folder ../shared/data not found (set SCANPREP_DATA_DIR)"; \
  }
