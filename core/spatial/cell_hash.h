// SPDX-License-Identifier: Apache-2.0
// Cubic cells of a fixed edge as hash keys, for grouping points that lie close together in one
// pass (duplicates.h, near_repeats.h) instead of a spatial index.
#pragma once

#include <bit>
#include <cmath>
#include <cstdint>

namespace scanprep {

// The cell number of coordinate `v` along one axis for cells of edge `edge`. A coordinate whose
// number would not fit 62 bits (or is not finite), or any coordinate when `edge` is 0, is its own
// cell, by its bits (−0 folded into 0, as floats compare), apart from every numbered one.
inline int64_t CellNumber(float v, double edge) {
  const double c = edge > 0 ? std::floor(double(v) / edge) : HUGE_VAL;
  return std::abs(c) < 0x1p62 ? static_cast<int64_t>(c)
                              : (int64_t{1} << 62) + std::bit_cast<uint32_t>(v + 0.0f);
}

// A hash of a cell's three numbers, keyed per process (HashKey): equal hashes of distinct cells
// are compared pairwise or share a bucket, and a fixed key would let a client craft them. What is
// grouped never depends on the key, only how it is found.
uint64_t HashCell(int64_t a, int64_t b, int64_t c);

}  // namespace scanprep
