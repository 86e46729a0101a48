// SPDX-License-Identifier: Apache-2.0
// The StreamEnd checksum against its definition in scanprep.proto, with values from another
// implementation (Python: zlib.crc32 over struct.pack('<...') of the arrays in field order).
#include <gtest/gtest.h>

#include "wire/stream_checksum.h"

namespace scanprep {
namespace {

// Every array, so a wrong order or a skipped array changes the value.
v1::PointChunk FullChunk() {
  v1::PointChunk chunk;
  for (float v : {1, 2, 3, 4, 5, 6}) chunk.add_xyz(v);
  for (uint32_t s : {0, 1}) chunk.add_scan_index(s);
  for (float q : {0.5f, 1.f}) chunk.add_quality(q);
  for (float n : {0, 0, 1, 0, 1, 0}) chunk.add_normal(n);
  chunk.set_flags(std::string("\x01\x08", 2));
  return chunk;
}

TEST(StreamChecksum, IsZlibCrc32OverEachChunksArraysInFieldOrder) {
  StreamChecksum checksum;
  EXPECT_EQ(checksum.crc32(), 0u);  // the empty stream
  checksum.Add(FullChunk());
  EXPECT_EQ(checksum.points(), 2u);
  // zlib.crc32(pack('<6f', 1..6) + pack('<2I', 0, 1) + pack('<2f', .5, 1) + pack('<6f', 0, 0, 1,
  // 0, 1, 0) + b'\x01\x08')
  EXPECT_EQ(checksum.crc32(), 0xd0dfb6d3u);

  // A second chunk continues the running CRC: the same as one CRC over both chunks' bytes.
  v1::PointChunk second;
  for (float v : {7, 8, 9}) second.add_xyz(v);
  second.add_scanline(7);
  checksum.Add(second);
  EXPECT_EQ(checksum.points(), 3u);
  EXPECT_EQ(checksum.crc32(), 0x2a5970bfu);
  EXPECT_EQ(checksum.End().points(), 3u);
  EXPECT_EQ(checksum.End().crc32(), 0x2a5970bfu);
}

TEST(StreamChecksum, EmptyChunksAndArraysLeaveItUnchanged) {
  StreamChecksum checksum;
  checksum.Add(FullChunk());
  checksum.Add(v1::PointChunk());
  EXPECT_EQ(checksum.crc32(), 0xd0dfb6d3u);
  EXPECT_EQ(checksum.points(), 2u);
}

TEST(StreamChecksum, OneFlippedBitChangesIt) {
  StreamChecksum intact, flipped;
  intact.Add(FullChunk());
  v1::PointChunk chunk = FullChunk();
  chunk.set_flags(std::string("\x01\x09", 2));
  flipped.Add(chunk);
  EXPECT_NE(intact.crc32(), flipped.crc32());
}

}  // namespace
}  // namespace scanprep
