// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: io::ReadPcd on arbitrary bytes (ascii, binary and LZF-compressed bodies).
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>
#include <vector>

#include "core/io/pcd.h"
#include "tests/fuzz/fuzz_checks.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  std::vector<std::string> warnings;
  auto cloud = scanprep::io::ReadPcd(in, "fuzz.pcd", warnings);
  if (!cloud.ok()) return 0;
  scanprep::fuzz::CheckCloud(*cloud);
  scanprep::fuzz::Require(cloud->scans.size() == 1, "a PCD file is one scan");
  if (cloud->scans[0].camera_position) {
    scanprep::fuzz::Require(cloud->scans[0].camera_position->allFinite(), "a finite sensor origin");
  }
  return 0;
}
