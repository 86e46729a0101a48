#include "core/ball_cache.h"

#include <algorithm>

#include "core/parallel.h"

namespace scanprep {

absl::Status BallCache::Gather(const PointCloud& cloud, const Neighbourhoods& nb,
                               const std::vector<float>& radius_of_scan,
                               const std::function<bool(const RadiusMatches&)>& keep,
                               const CancelToken& cancel) {
  const size_t n = cloud.size();
  // Balls are asked in grid order (neighbouring balls read the same cells) in fixed blocks,
  // then each block's members are moved to their points' slots in index order.
  const std::span<const uint32_t> order = nb.order();
  constexpr size_t kBlock = 4096;
  const size_t blocks = (n + kBlock - 1) / kBlock;
  std::vector<std::vector<uint32_t>> block_members(blocks);
  start_.assign(n + 1, 0);
  absl::Status status = ParallelFor(blocks, cancel, [&](size_t first, size_t last) {
    RadiusMatches matches;
    for (size_t b = first; b < last; ++b) {
      for (size_t v = b * kBlock; v < std::min(n, (b + 1) * kBlock); ++v) {
        const uint32_t i = order[v];
        const float radius = radius_of_scan[cloud.scan[i]];
        if (cloud.removed(i) || radius <= nb.dk(i)) continue;
        nb.Within(cloud, i, radius, matches);
        if (!keep(matches)) continue;
        start_[i + 1] = static_cast<uint32_t>(matches.size());
        for (const auto& match : matches) block_members[b].push_back(match.first);
      }
    }
  }, /*grain=*/1);
  if (!status.ok()) return status;
  for (size_t i = 0; i < n; ++i) start_[i + 1] += start_[i];
  members_.resize(start_[n]);
  return ParallelFor(blocks, cancel, [&](size_t first, size_t last) {
    for (size_t b = first; b < last; ++b) {
      const uint32_t* from = block_members[b].data();
      for (size_t v = b * kBlock; v < std::min(n, (b + 1) * kBlock); ++v) {
        const uint32_t i = order[v];
        std::copy(from, from + (start_[i + 1] - start_[i]), members_.begin() + start_[i]);
        from += start_[i + 1] - start_[i];
      }
      block_members[b] = {};
    }
  }, /*grain=*/1);
}

bool BallCache::Within(const PointCloud& cloud, size_t i, RadiusMatches& out) const {
  // A gathered ball holds at least i itself.
  if (start_.empty() || start_[i + 1] == start_[i]) return false;
  out.clear();
  const Eigen::Vector3f p = cloud.point(i);
  for (uint32_t m = start_[i]; m < start_[i + 1]; ++m) {
    const uint32_t j = members_[m];
    if (!cloud.removed(j)) out.emplace_back(j, (cloud.point(j) - p).squaredNorm());
  }
  return true;
}

}  // namespace scanprep
