// SPDX-License-Identifier: Apache-2.0
// The count and CRC-32 a StreamEnd carries, computed over the PointChunks of a stream as
// scanprep.proto defines it. One definition for both directions and both sides: the server checks
// uploads and sums results with it, the client sums uploads and checks results.
#pragma once

#include <cstdint>

#include "scanprep/v1/scanprep.pb.h"

namespace scanprep {

class StreamChecksum {
 public:
  // Adds one chunk, in stream order.
  void Add(const v1::PointChunk& chunk);

  uint64_t points() const { return points_; }
  uint32_t crc32() const { return crc32_; }
  v1::StreamEnd End() const;

 private:
  uint64_t points_ = 0;
  uint32_t crc32_ = 0;
};

}  // namespace scanprep
