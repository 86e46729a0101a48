// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: io::ReadE57Bytes on arbitrary bytes (pages and CRCs, the XML section, packets
// and bit-packed fields). Seeds: tests/fuzz/make_e57_seeds.py.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "core/io/e57.h"
#include "tests/fuzz/fuzz_checks.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::vector<std::string> warnings;
  auto cloud = scanprep::io::ReadE57Bytes(
      std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.e57", warnings);
  if (!cloud.ok()) return 0;
  scanprep::fuzz::CheckCloud(*cloud);
  for (const scanprep::ScanMeta& scan : cloud->scans) {
    if (scan.camera_position) {
      scanprep::fuzz::Require(scan.camera_position->allFinite(), "a finite scanner origin");
    }
  }
  return 0;
}
