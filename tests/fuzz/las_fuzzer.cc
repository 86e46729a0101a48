// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: io::ReadLasBytes on arbitrary bytes (header fields, counts and offsets,
// every point format). Seeds: tests/fuzz/make_las_seeds.py.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "core/io/las.h"
#include "tests/fuzz/fuzz_checks.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::vector<std::string> warnings;
  auto cloud = scanprep::io::ReadLasBytes(
      std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.las", warnings);
  if (!cloud.ok()) return 0;
  scanprep::fuzz::CheckCloud(*cloud);
  scanprep::fuzz::Require(cloud->scans.size() == 1, "a LAS file is one scan");
  return 0;
}
