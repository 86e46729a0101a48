// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: io::ReadE57Bytes on arbitrary bytes (the XML section, packets and bit-packed
// fields). Every 1024-byte page gets its correct CRC-32C first, as a mutation would almost never
// keep one, so the fuzzer reaches past the page check (a unit test covers damaged pages).
// Seeds: tests/fuzz/make_e57_seeds.py.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "core/io/e57.h"
#include "tests/fuzz/fuzz_checks.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  constexpr size_t kPage = 1024, kPayload = kPage - 4;
  std::string file(reinterpret_cast<const char*>(data), size);
  for (size_t at = 0; at + kPage <= file.size(); at += kPage) {
    const uint32_t crc = scanprep::io::E57PageChecksum(std::string_view(file).substr(at, kPayload));
    for (int b = 0; b < 4; ++b) file[at + kPayload + b] = static_cast<char>(crc >> (24 - 8 * b));
  }
  std::vector<std::string> warnings;
  auto cloud = scanprep::io::ReadE57Bytes(file, "fuzz.e57", warnings);
  if (!cloud.ok()) return 0;
  scanprep::fuzz::CheckCloud(*cloud);
  for (const scanprep::ScanMeta& scan : cloud->scans) {
    if (scan.camera_position) {
      scanprep::fuzz::Require(scan.camera_position->allFinite(), "a finite scanner origin");
    }
  }
  return 0;
}
