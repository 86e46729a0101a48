// SPDX-License-Identifier: Apache-2.0
// Reading the viewing quality q̂ (PointMeasures::quality) as the merge and the thinning do: in
// descending order, and whether it tells points apart at all.
#pragma once

#include <algorithm>
#include <bit>
#include <cstdint>
#include <vector>

#include "core/base/point_cloud.h"

namespace scanprep {

// Whether every unremoved point has the same q̂ (no scan had sensor poses or a per-point
// quality): then a weight or a choice by q̂ tells nothing apart.
bool UniformQuality(const PointCloud& cloud, const std::vector<float>& quality);

// A sort key of point i that orders by descending q̂, then by index, in its low 62 bits: q̂ in
// [0, 1] (anything else clamped) as 1 − q̂ in float bits, which non-negative floats order like.
// Sorting such keys beats a comparator that looks q̂ up by index, which would miss the cache on
// nearly every comparison of a million-point cloud.
inline uint64_t DescendingQualityKey(float quality, uint32_t i) {
  constexpr uint64_t kOne = std::bit_cast<uint32_t>(1.f);
  const uint64_t bits = quality > 0 ? std::bit_cast<uint32_t>(std::min(quality, 1.f)) : 0;
  return (kOne - bits) << 32 | i;
}

}  // namespace scanprep
