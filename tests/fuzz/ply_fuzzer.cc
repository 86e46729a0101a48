// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: io::ReadPly on arbitrary bytes (ASCII and binary PLY share the header parser).
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>

#include "core/io/ply.h"
#include "tests/fuzz/fuzz_checks.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  std::vector<std::string> ply_warnings;
  auto cloud = scanprep::io::ReadPly(in, "fuzz.ply", ply_warnings);
  if (cloud.ok()) scanprep::fuzz::CheckCloud(*cloud);
  return 0;
}
