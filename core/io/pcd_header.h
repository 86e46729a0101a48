// SPDX-License-Identifier: Apache-2.0
// PCD header model and parser (internal to the PCD reader).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"

namespace scanprep::io::pcd {

enum class Data { kAscii, kBinary, kBinaryCompressed };

struct Field {
  std::string name;
  uint32_t size = 4;       // bytes per value: 1, 2, 4 or 8
  char type = 'F';         // 'I' signed, 'U' unsigned, 'F' floating point
  uint32_t count = 1;      // values per point
  size_t offset = 0;       // byte offset of the first value in a binary point record
  size_t value_index = 0;  // index of the first value among a point's values (ASCII columns)
};

struct Header {
  std::vector<Field> fields;
  uint64_t width = 0, height = 1, points = 0;
  size_t point_bytes = 0;   // one binary point record: Σ size·count
  size_t point_values = 0;  // values per point: Σ count
  // VIEWPOINT tx ty tz qw qx qy qz, when the header has that line.
  std::optional<std::array<double, 7>> viewpoint;
  Data data = Data::kAscii;
  size_t body_offset = 0;      // first byte after the DATA line
  size_t body_first_line = 0;  // line number of the first body line (ASCII)
};

// Parses and validates the header of `data` (the whole file): every keyword's syntax, the
// agreement of FIELDS/SIZE/TYPE/COUNT and of WIDTH·HEIGHT with POINTS, and — for ascii and binary
// bodies — that the body can hold POINTS points, so callers may size arrays from the count.
absl::StatusOr<Header> ParseHeader(std::string_view data, const std::string& name);

}  // namespace scanprep::io::pcd
