// SPDX-License-Identifier: Apache-2.0
// Values gathered per scan by a parallel loop, for statistics that do not depend on the order
// the values arrive in (a median, deciles): each block collects its (scan, value) pairs and
// appends them under a lock. The stages' per-scan medians (noise σ̂, spacing) ran serially over
// every point, which a 16-core run would wait for.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <mutex>
#include <utility>
#include <vector>

#include "absl/status/statusor.h"
#include "core/base/cancel.h"
#include "core/base/parallel.h"
#include "core/base/point_cloud.h"
#include "core/base/status_macros.h"

namespace scanprep {

// How many points each scan of `cloud` holds.
inline std::vector<size_t> ScanPointCounts(const PointCloud& cloud) {
  std::vector<size_t> count(cloud.scans.size(), 0);
  for (const uint32_t s : cloud.scan) ++count[s];
  return count;
}

// For the items [0, n) (points, scanlines) of `cloud`: emit(item, add) calls add(scan, value)
// for each value the item gives, at most one per point of the scan. Returns the values of each
// scan, in an order that depends on the threads. Each scan's list is reserved for its points by
// the calling thread, so the appends never reallocate and the workers allocate only their
// block's pairs (memory grown in a worker thread's arena stays with the process).
template <typename Emit>
absl::StatusOr<std::vector<std::vector<float>>> ValuesPerScan(const PointCloud& cloud, size_t n,
                                                              const CancelToken& cancel,
                                                              Emit&& emit, size_t grain = 16384) {
  const std::vector<size_t> points = ScanPointCounts(cloud);
  std::vector<std::vector<float>> per_scan(cloud.scans.size());
  for (size_t s = 0; s < per_scan.size(); ++s) per_scan[s].reserve(points[s]);
  std::mutex mu;
  SCANPREP_RETURN_IF_ERROR(ParallelFor(
      n, cancel,
      [&](size_t begin, size_t end) {
        std::vector<std::pair<uint32_t, float>> found;
        const auto add = [&](uint32_t scan, float value) { found.emplace_back(scan, value); };
        for (size_t item = begin; item < end; ++item) emit(item, add);
        std::lock_guard lock(mu);
        for (const auto& [scan, value] : found) per_scan[scan].push_back(value);
      },
      grain));
  return per_scan;
}

// The upper median of `values` (reordered); 0 for none.
inline float UpperMedian(std::vector<float>& values) {
  if (values.empty()) return 0.f;
  const auto mid = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), mid, values.end());
  return *mid;
}

}  // namespace scanprep
