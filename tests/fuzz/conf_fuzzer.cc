// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: io::ReadConf on arbitrary text; every returned pose must be a finite rigid
// motion (unit quaternion, finite translation).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>

#include "core/io/conf.h"
#include "tests/fuzz/fuzz_checks.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  auto entries = scanprep::io::ReadConf(in, "fuzz.conf");
  if (!entries.ok()) return 0;
  for (const scanprep::io::ConfEntry& e : *entries) {
    scanprep::fuzz::Require(!e.file.empty(), "an entry names its file");
    scanprep::fuzz::Require(e.pose.translation.allFinite(), "finite translation");
    scanprep::fuzz::Require(
        e.pose.rotation.coeffs().allFinite() && std::abs(e.pose.rotation.norm() - 1.0) < 1e-9,
        "unit quaternion");
  }
  return 0;
}
