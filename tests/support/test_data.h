// SPDX-License-Identifier: Apache-2.0
// Locates the real scans in ../shared/data; tests that need them skip when it is absent.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "core/base/point_cloud.h"

namespace scanprep::testing {

// The shared data folder (override with SCANPREP_DATA_DIR), or empty when it does not exist.
std::filesystem::path SharedDataDir();

// The range scans `names` (PLY files `name`.ply in `dir`) registered by the scanalyze file `conf`,
// in the common frame and in mm (the files are in metres), one scan each with the scanner's view
// direction (its own z axis) and scanline spacing; the range grid's rows are the scanlines.
// Records a test failure and returns an empty cloud when a file cannot be read.
PointCloud LoadRangeScansMm(const std::filesystem::path& dir, const std::string& conf,
                            const std::vector<std::string>& names, double scanline_spacing_mm);

}  // namespace scanprep::testing

// Skips the current test with a clear message when ../shared/data is missing.
#define SCANPREP_REQUIRE_SHARED_DATA(dir_var)                                                 \
  const std::filesystem::path dir_var = ::scanprep::testing::SharedDataDir();                 \
  if (dir_var.empty()) {                                                                      \
    GTEST_SKIP() << "real-scan data folder ../shared/data not found (set SCANPREP_DATA_DIR)"; \
  }
