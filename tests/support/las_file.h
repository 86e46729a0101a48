// SPDX-License-Identifier: Apache-2.0
// LAS files written from the ASPRS specification's layouts, independently of the reader, for the
// tests that read them (io_las_test, the CLI's).
#pragma once

#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

namespace scanprep::testing {

// Stores `value` at byte `at` of `out`, little-endian as LAS is (the tests run on x86).
template <class T>
void PutAt(std::string& out, size_t at, T value) {
  std::memcpy(out.data() + at, &value, sizeof value);
}

struct LasPoint {
  int32_t x, y, z;
  uint16_t intensity;
  bool direction = false, edge = false;
  double angle = 0;  // degrees
};

// A LAS file of `points` in version 1.`minor`, point format `format`, records of `record` bytes
// (0 = the format's own size), scale 0.001 and offset (1000, 2000, 3000), one variable-length
// record before the points. A format with colour has red, green, blue = intensity + 1, + 2, + 3;
// one with GPS time has 1e5 + intensity / 4 seconds.
std::string LasFile(int minor, int format, const std::vector<LasPoint>& points, int record = 0);

}  // namespace scanprep::testing
