// SPDX-License-Identifier: Apache-2.0
#include "core/spatial/ball_cache.h"

#include <algorithm>

#include "core/pipeline/parallel.h"

namespace scanprep {

absl::Status BallCache::Gather(const PointCloud& cloud, const Neighbourhoods& nb,
                               const std::vector<float>& radius_of_scan,
                               const std::function<bool(const RadiusMatches&)>& keep,
                               const CancelToken& cancel) {
  const size_t n = cloud.size();
  // Balls are asked in grid order (neighbouring balls read the same cells) in fixed blocks.
  const std::span<const uint32_t> order = nb.order();
  constexpr size_t kBlock = 4096;
  const size_t blocks = (n + kBlock - 1) / kBlock;
  blocks_.assign(blocks, {});
  slots_.assign(n, Slot{});
  return ParallelFor(
      blocks, cancel,
      [&](size_t first, size_t last) {
        RadiusMatches matches;
        for (size_t b = first; b < last; ++b) {
          std::vector<uint32_t>& members = blocks_[b];
          for (size_t v = b * kBlock; v < std::min(n, (b + 1) * kBlock); ++v) {
            const uint32_t i = order[v];
            const float radius = radius_of_scan[cloud.scan[i]];
            if (cloud.removed(i) || radius <= nb.dk(i)) continue;
            nb.Within(cloud, i, radius, matches);
            if (!keep(matches)) continue;
            slots_[i] = {static_cast<uint32_t>(b), static_cast<uint32_t>(members.size()),
                         static_cast<uint32_t>(matches.size())};
            for (const auto& match : matches) members.push_back(match.first);
          }
          members.shrink_to_fit();
        }
      },
      /*grain=*/1);
}

bool BallCache::Within(const PointCloud& cloud, size_t i, RadiusMatches& out) const {
  // A gathered ball holds at least i itself.
  if (slots_.empty() || slots_[i].size == 0) return false;
  out.clear();
  const Slot& slot = slots_[i];
  const uint32_t* members = blocks_[slot.block].data() + slot.begin;
  for (uint32_t m = 0; m < slot.size; ++m) {
    const uint32_t j = members[m];
    if (!cloud.removed(j)) out.emplace_back(j, cloud.squared_distance(i, j));
  }
  return true;
}

}  // namespace scanprep
