// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: io::ReadXyz on arbitrary text, with and without scanline splitting.
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>

#include "core/io/xyz.h"
#include "tests/fuzz/fuzz_checks.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  // profile_gap = 0 takes no scanlines; 1.0 makes every jump > 1 start a new scanline.
  for (double profile_gap : {0.0, 1.0}) {
    std::istringstream in(text);
    std::vector<std::string> warnings;
    auto cloud = scanprep::io::ReadXyz(in, "fuzz.xyz", warnings, profile_gap);
    if (!cloud.ok()) continue;
    scanprep::fuzz::CheckCloud(*cloud);
    if (cloud->size() > 0) {
      scanprep::fuzz::Require(cloud->has_scanlines() == (profile_gap > 0),
                              "scanlines exactly when a profile gap is given");
    }
  }
  return 0;
}
