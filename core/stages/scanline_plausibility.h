// SPDX-License-Identifier: Apache-2.0
// Do a scan's scanline indices describe profiles? A laser line's points form a curve: near any
// point, the points of its own scanline lie along one direction. Indices that hold areas instead
// (every point on scanline 0, a reader or client that numbers rows wrongly) spread them over the
// surface, and the stages that trust them (r_min from Δs, the scanline curvature, the scanline
// spacing) then work on a fiction whose only symptom is a capped radius.
#pragma once

#include <cstddef>

#include "absl/status/status.h"
#include "core/base/point_cloud.h"
#include "core/spatial/neighbourhoods.h"
#include "core/stages/stage_reporter.h"

namespace scanprep {

// Points of a scan judged, at most: an even sample, so the check costs O(k) per sampled point.
inline constexpr size_t kScanlineSamplePoints = 2048;
// Near a point, its scanline's points within its k nearest are a profile when their spread across
// their main direction is under this share of the spread along it (a 90° corner of a profile:
// about a third; an area: about one).
inline constexpr double kProfileSpreadRatio = 0.25;

// Warns SCANLINES_IMPLAUSIBLE for each line scan with scanline indices where more than half of
// the judged points (those with at least 5 of their scanline among their k nearest) see their
// scanline spread as an area. Needs the neighbourhoods; CANCELLED when the job's token fires.
absl::Status WarnIfScanlinesImplausible(const PointCloud& cloud, const Neighbourhoods& nb,
                                        StageReporter& out);

}  // namespace scanprep
