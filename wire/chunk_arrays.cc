// SPDX-License-Identifier: Apache-2.0
#include "wire/chunk_arrays.h"

#include <algorithm>
#include <bit>
#include <cstring>
#include <string>

#include "absl/strings/str_cat.h"

namespace scanprep {
namespace {

// The packed form is the values' own memory on these hosts (as the checksum assumes).
static_assert(std::endian::native == std::endian::little);

// One array in its two forms, as member accessors of the generated message.
template <class T>
struct ArrayPair {
  const char* name;
  int width;  // values per point
  google::protobuf::RepeatedField<T>* (v1::PointChunk::*repeated)();
  std::string* (v1::PointChunk::*packed)();
  const google::protobuf::RepeatedField<T>& (v1::PointChunk::*values)() const;
  const std::string& (v1::PointChunk::*bytes)() const;
};

// Calls visit(pair) for each of the seven arrays, in field order.
template <class Visit>
void ForEachArray(Visit&& visit) {
  using C = v1::PointChunk;
  visit(
      ArrayPair<float>{"xyz", 3, &C::mutable_xyz, &C::mutable_xyz_packed, &C::xyz, &C::xyz_packed});
  visit(ArrayPair<uint32_t>{"scan_index", 1, &C::mutable_scan_index, &C::mutable_scan_index_packed,
                            &C::scan_index, &C::scan_index_packed});
  visit(ArrayPair<uint32_t>{"scanline", 1, &C::mutable_scanline, &C::mutable_scanline_packed,
                            &C::scanline, &C::scanline_packed});
  visit(ArrayPair<float>{"quality", 1, &C::mutable_quality, &C::mutable_quality_packed, &C::quality,
                         &C::quality_packed});
  visit(ArrayPair<float>{"intensity", 1, &C::mutable_intensity, &C::mutable_intensity_packed,
                         &C::intensity, &C::intensity_packed});
  visit(ArrayPair<float>{"normal", 3, &C::mutable_normal, &C::mutable_normal_packed, &C::normal,
                         &C::normal_packed});
  visit(ArrayPair<uint32_t>{"source_index", 1, &C::mutable_source_index,
                            &C::mutable_source_index_packed, &C::source_index,
                            &C::source_index_packed});
}

}  // namespace

absl::Status UnpackArrays(v1::PointChunk& chunk, std::string& bad_array) {
  absl::Status status;
  ForEachArray([&](auto pair) {
    std::string& packed = *(chunk.*pair.packed)();
    if (!status.ok() || packed.empty()) return;
    auto& repeated = *(chunk.*pair.repeated)();
    if (!repeated.empty() || packed.size() % 4 != 0) {
      bad_array = absl::StrCat(pair.name, "_packed");
    }
    if (!repeated.empty()) {
      status = absl::InvalidArgumentError(absl::StrCat(
          pair.name, " and ", pair.name, "_packed are both set; send an array in one form"));
      return;
    }
    if (packed.size() % 4 != 0) {
      status = absl::InvalidArgumentError(
          absl::StrCat(pair.name, "_packed has ", packed.size(), " bytes, not a multiple of 4"));
      return;
    }
    repeated.Resize(static_cast<int>(packed.size() / 4), {});
    std::memcpy(repeated.mutable_data(), packed.data(), packed.size());
    packed.clear();
  });
  return status;
}

void PackArrays(v1::PointChunk& chunk) {
  ForEachArray([&](auto pair) {
    auto& repeated = *(chunk.*pair.repeated)();
    if (repeated.empty()) return;
    std::string& packed = *(chunk.*pair.packed)();
    packed.assign(reinterpret_cast<const char*>(repeated.data()), repeated.size() * 4);
    repeated.Clear();
  });
}

uint64_t ChunkPoints(const v1::PointChunk& chunk) {
  return (chunk.xyz_size() + chunk.xyz_packed().size() / 4) / 3;
}

bool HasPackedArrays(const v1::PointChunk& chunk) {
  return !chunk.xyz_packed().empty() || !chunk.scan_index_packed().empty() ||
         !chunk.scanline_packed().empty() || !chunk.quality_packed().empty() ||
         !chunk.intensity_packed().empty() || !chunk.normal_packed().empty() ||
         !chunk.source_index_packed().empty();
}

v1::PointChunk SliceChunk(const v1::PointChunk& chunk, uint64_t begin, uint64_t end) {
  v1::PointChunk slice;
  ForEachArray([&](auto pair) {
    const auto& values = (chunk.*pair.values)();
    const uint64_t size = values.size();
    const uint64_t from = std::min(begin * pair.width, size);
    const uint64_t to = std::min(end * pair.width, size);
    (slice.*pair.repeated)()->Add(values.begin() + from, values.begin() + to);
  });
  return slice;
}

void AppendChunk(const v1::PointChunk& from, v1::PointChunk& to) {
  ForEachArray([&](auto pair) {
    const auto& values = (from.*pair.values)();
    (to.*pair.repeated)()->Add(values.begin(), values.end());
    (to.*pair.packed)()->append((from.*pair.bytes)());
  });
  to.mutable_flags()->append(from.flags());
}

}  // namespace scanprep
