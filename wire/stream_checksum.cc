// SPDX-License-Identifier: Apache-2.0
#include "wire/stream_checksum.h"

#include <bit>

#include <zlib.h>

#include "wire/chunk_arrays.h"

namespace scanprep {
namespace {

// The checksum is over the little-endian bytes, which on these hosts are the arrays' own memory;
// a big-endian port would have to swap each value first.
static_assert(std::endian::native == std::endian::little);

// Empty arrays are skipped: zlib answers 0, not `crc`, for a null buffer, which is what an empty
// RepeatedField's data() may be.
uint32_t Update(uint32_t crc, const void* data, size_t bytes) {
  return bytes == 0 ? crc : crc32_z(crc, static_cast<const Bytef*>(data), bytes);
}

// One array, in whichever form it came (the packed bytes are the repeated values' memory).
template <class T>
uint32_t Update(uint32_t crc, const google::protobuf::RepeatedField<T>& values,
                const std::string& packed) {
  static_assert(sizeof(T) == 4);
  crc = Update(crc, values.data(), values.size() * sizeof(T));
  return Update(crc, packed.data(), packed.size());
}

}  // namespace

void StreamChecksum::Add(const v1::PointChunk& chunk) {
  points_ += ChunkPoints(chunk);
  uint32_t crc = crc32_;
  crc = Update(crc, chunk.xyz(), chunk.xyz_packed());
  crc = Update(crc, chunk.scan_index(), chunk.scan_index_packed());
  crc = Update(crc, chunk.scanline(), chunk.scanline_packed());
  crc = Update(crc, chunk.quality(), chunk.quality_packed());
  crc = Update(crc, chunk.intensity(), chunk.intensity_packed());
  crc = Update(crc, chunk.normal(), chunk.normal_packed());
  crc = Update(crc, chunk.flags().data(), chunk.flags().size());
  crc = Update(crc, chunk.source_index(), chunk.source_index_packed());
  crc32_ = crc;
}

v1::StreamEnd StreamChecksum::End() const {
  v1::StreamEnd end;
  end.set_points(points_);
  end.set_crc32(crc32_);
  return end;
}

}  // namespace scanprep
