// SPDX-License-Identifier: Apache-2.0
// Radius balls that the k-NN lists cannot answer (radius > d_k), gathered once from the grid in
// parallel and kept in CSR form by point index, for a stage that asks the same balls again
// (correction's rounds). The points must not move while it is in use.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "absl/status/status.h"
#include "core/pipeline/cancel.h"
#include "core/point_cloud.h"
#include "core/spatial/neighbourhoods.h"

namespace scanprep {

class BallCache {
 public:
  // Asks the ball of every unremoved point i whose radius_of_scan[scan(i)] exceeds d_k(i) and
  // keeps those that `keep` accepts (a caller that knows it will not ask a ball again saves its
  // memory: at 4 M points the balls take gigabytes).
  absl::Status Gather(const PointCloud& cloud, const Neighbourhoods& nb,
                      const std::vector<float>& radius_of_scan,
                      const std::function<bool(const RadiusMatches&)>& keep,
                      const CancelToken& cancel);

  // Like Neighbourhoods::Within for a kept ball, skipping points removed since; false when i
  // has no kept ball.
  bool Within(const PointCloud& cloud, size_t i, RadiusMatches& out) const;

 private:
  // Balls stay in the blocks they were gathered in: one contiguous copy would double the peak,
  // and at 4 M points the balls alone take a gigabyte.
  struct Slot {
    uint32_t block = 0, begin = 0, size = 0;  // ball of i: blocks_[block][begin, begin + size)
  };
  std::vector<Slot> slots_;
  std::vector<std::vector<uint32_t>> blocks_;
};

}  // namespace scanprep
