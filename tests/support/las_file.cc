// SPDX-License-Identifier: Apache-2.0
// The writer behind LasFile: the ASPRS public header and point records, byte by byte.
#include "tests/support/las_file.h"

#include <cmath>
#include <cstring>

namespace scanprep::testing {

std::string LasFile(int minor, int format, const std::vector<LasPoint>& points, int record) {
  const int sizes[] = {20, 28, 26, 34, 57, 63, 30, 36, 38, 59, 67};
  // The spec's place of red, green, blue in the formats that have them (2, 3, 5, 7, 8, 10).
  const int rgb[] = {0, 0, 20, 28, 0, 28, 0, 30, 30, 0, 30};
  // The GPS time's place: after the point source ID (byte 20, 22 in formats 6 to 10), except 0, 2.
  const int gps[] = {0, 20, 0, 20, 20, 20, 22, 22, 22, 22, 22};
  if (record == 0) record = sizes[format];
  const size_t header = minor >= 4 ? 375 : 227;
  const size_t vlr = 54;  // one variable-length record's header, skipped by the offset
  std::string out(header + vlr + points.size() * record, '\0');
  std::memcpy(out.data(), "LASF", 4);
  out[24] = 1, out[25] = static_cast<char>(minor);
  PutAt<uint16_t>(out, 94, static_cast<uint16_t>(header));
  PutAt<uint32_t>(out, 96, static_cast<uint32_t>(header + vlr));
  PutAt<uint32_t>(out, 100, 1);
  out[104] = static_cast<char>(format);
  PutAt<uint16_t>(out, 105, static_cast<uint16_t>(record));
  PutAt<uint32_t>(out, 107, minor >= 4 ? 0 : static_cast<uint32_t>(points.size()));
  if (minor >= 4) PutAt<uint64_t>(out, 247, points.size());
  for (int k = 0; k < 3; ++k) {
    PutAt<double>(out, 131 + 8 * k, 0.001);
    PutAt<double>(out, 155 + 8 * k, 1000.0 * (k + 1));
  }
  for (size_t i = 0; i < points.size(); ++i) {
    const size_t at = header + vlr + i * record;
    const LasPoint& p = points[i];
    PutAt(out, at, p.x), PutAt(out, at + 4, p.y), PutAt(out, at + 8, p.z);
    PutAt(out, at + 12, p.intensity);
    for (int channel = 0; rgb[format] != 0 && channel < 3; ++channel) {
      PutAt<uint16_t>(out, at + rgb[format] + 2 * channel,
                      static_cast<uint16_t>(p.intensity + channel + 1));
    }
    if (gps[format] != 0) PutAt<double>(out, at + gps[format], 1e5 + 0.25 * p.intensity);
    const uint8_t flags = (p.direction ? 0x40 : 0) | (p.edge ? 0x80 : 0);
    if (format >= 6) {
      out[at + 14] = 0x11;                             // return 1 of 1
      out[at + 15] = static_cast<char>(flags | 0x10);  // scanner channel 1 beside them
      PutAt<int16_t>(out, at + 18, static_cast<int16_t>(std::lround(p.angle / 0.006)));
    } else {
      out[at + 14] = static_cast<char>(flags | 0x09);  // return 1 of 1
      out[at + 16] = static_cast<char>(std::lround(p.angle));
    }
  }
  return out;
}

}  // namespace scanprep::testing
