// SPDX-License-Identifier: Apache-2.0
// Radius balls that the k-NN lists cannot answer (radius > d_k), gathered once from the grid in
// parallel for a stage that asks the same balls again (correction's rounds). The points must not
// move while it is in use.
//
// Compact: a ball's member indices are kept as varints of their differences, in the grid's order
// (a cell's points in index order), about 1.5 bytes a member instead of 4.
// Bounded: the balls kept take at most kBallCacheBytesPerPoint per point of the cloud, so a job
// whose balls are all at their cap cannot make the cache its largest allocation; the balls beyond
// the budget (the last blocks gathered, in a fixed order) are asked from the grid each time.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "absl/status/status.h"
#include "core/pipeline/cancel.h"
#include "core/point_cloud.h"
#include "core/spatial/neighbourhoods.h"

namespace scanprep {

// The cache's budget. At the default k a ball of correction's largest radius, 2·r_g, holds about
// 84 points and takes about 110 bytes, so even a cloud that lies wholly in an overlap fits; a
// ball at its cap of 32·k points takes about 800.
inline constexpr size_t kBallCacheBytesPerPoint = 128;

class BallCache {
 public:
  // Asks the ball of every unremoved point i whose radius_of_scan[scan(i)] exceeds d_k(i) and
  // keeps those that `keep` accepts (a caller that knows it will not ask a ball again saves its
  // memory), while the budget lasts.
  absl::Status Gather(const PointCloud& cloud, const Neighbourhoods& nb,
                      const std::vector<float>& radius_of_scan,
                      const std::function<bool(const RadiusMatches&)>& keep,
                      const CancelToken& cancel);

  // Gathered and turned down by `keep`.
  bool Rejected(size_t i) const { return !state_.empty() && state_[i].block == kRejected; }
  // Like Neighbourhoods::Within(cloud, i, radius) for a ball that Gather() asked, skipping the
  // points removed since: from the cache when it was kept, else from the grid. A ball that was at
  // its cap (max_ball_points(), the nearest) when gathered keeps those points; asked from the grid
  // after removals it may reach the next ones instead.
  void Within(const PointCloud& cloud, const Neighbourhoods& nb, size_t i, float radius,
              RadiusMatches& out) const;

  // Balls kept, balls asked but beyond the budget, and the bytes the kept ones take.
  size_t kept() const { return kept_; }
  size_t over_budget() const { return over_budget_; }
  size_t bytes() const { return bytes_; }
  // Points asked per round of Gather(): the budget is exceeded by at most this many balls.
  static size_t PointsPerRound();

 private:
  static constexpr uint32_t kNotKept = UINT32_MAX, kRejected = UINT32_MAX - 1;
  struct Slot {
    uint32_t block = kNotKept;  // or kRejected
    uint32_t begin = 0;         // ball of i: blocks_[block] from byte `begin`: count, members
  };
  std::vector<Slot> state_;
  // Balls stay in the blocks they were gathered in: one contiguous copy would double the peak.
  std::vector<std::vector<uint8_t>> blocks_;
  size_t kept_ = 0, over_budget_ = 0, bytes_ = 0;
};

}  // namespace scanprep
