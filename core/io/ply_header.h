// SPDX-License-Identifier: Apache-2.0
// PLY header model and parser (internal to the PLY reader).
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "core/base/point_attributes.h"

namespace scanprep::io::ply {

enum class Format { kAscii, kBinaryLittleEndian, kBinaryBigEndian };
// PLY's eight scalar types are the attribute types, so a property read keeps its type as it is
// (AttributeBytes, IsIntegerAttribute); the parser never gives kFloat32Bits.
using ScalarType = AttributeType;

// The PLY name of `type` ("uchar"; kFloat32Bits: "float"), as the writer declares a property.
std::string TypeName(ScalarType type);

struct Property {
  std::string name;
  ScalarType type = ScalarType::kFloat32;  // the item type for a list
  bool is_list = false;
  ScalarType count_type = ScalarType::kUint8;
};

struct Element {
  std::string name;
  uint64_t count = 0;
  std::vector<Property> properties;
};

struct Header {
  Format format = Format::kAscii;
  std::vector<Element> elements;
  // Stanford range-grid dimensions from `obj_info num_cols N` / `obj_info num_rows N`.
  std::optional<uint64_t> num_cols, num_rows;
  size_t body_offset = 0;      // first byte after the end_header line
  size_t body_first_line = 0;  // line number of the first body line (ASCII)
};

// Parses and validates the header of `data` (the whole file). Besides syntax it rejects element
// counts the data section cannot possibly hold, so callers may size arrays from the counts.
absl::StatusOr<Header> ParseHeader(std::string_view data, const std::string& name);

}  // namespace scanprep::io::ply
