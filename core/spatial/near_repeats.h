// SPDX-License-Identifier: Apache-2.0
// Near repeats: points of a scan that lie within the sensor's resolution of a point of a
// lower-numbered scan. A scan sent twice is one case; a scan re-exported (a float written as
// decimal text and read back, a registration that shifted it by a rounding error) is the same
// data a few ULP or 1e-4 mm apart, and an exact comparison misses it. Two independent
// measurements of one surface sample it at other positions, or, from one pose, differ by the
// noise along the ray: few of their points come that close.
#pragma once

#include <cstdint>
#include <vector>

#include "absl/status/statusor.h"
#include "core/base/cancel.h"
#include "core/base/point_cloud.h"

namespace scanprep {

// Per scan, how many of its points lie within `tolerance` (Euclidean; 0 = the same x, y, z) of
// one of `standing` (points that stand for the others: one per resolution cube and scan) of a
// lower-numbered scan. Counted in full in the scans where an even sample of kNearRepeatSample of
// their points finds one; any other scan is counted 0 (fewer than about 1 in kNearRepeatSample of
// its points can be near), and so is a scan the tolerance does not resolve (its own standing
// points that close at over 5 % of its sample: a unit slip, not a repeat). At most
// kNearRepeatCandidates are read per cell a point looks in, so the work is O(n) at any density;
// O(n) memory while it runs. Cancellable.
absl::StatusOr<std::vector<uint64_t>> CountNearRepeats(const PointCloud& cloud,
                                                       const std::vector<uint32_t>& standing,
                                                       double tolerance, const CancelToken& cancel);

// Points of a scan that decide whether it is counted: an ordinary job (no scan near another's
// points) pays one look per standing point into a table of these, which stays in cache.
inline constexpr size_t kNearRepeatSample = 4096;
// Candidates read per cell: on a surface a cell holds a few standing points per scan (it is at most
// a stated point spacing across when the tolerance is the resolution ε).
inline constexpr size_t kNearRepeatCandidates = 64;

}  // namespace scanprep
