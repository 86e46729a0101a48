// SPDX-License-Identifier: Apache-2.0
// Δp per scan, the spacing of a scan's points along its scanlines. The measures, correction,
// health and simplification stages each take it of the points unremoved when they run (after
// the merge a scan's spacing is that of what it kept), so it is not computed once per job.
#pragma once

#include <vector>

#include "absl/status/statusor.h"
#include "core/base/cancel.h"
#include "core/base/point_cloud.h"
#include "core/spatial/neighbourhoods.h"

namespace scanprep {

// Measured (median consecutive distance) when the scan has scanlines, else the scanner's nominal
// point_spacing, else the median nearest-neighbour distance of the scan in `nb` (none: 0).
// CANCELLED when the job's token fires.
absl::StatusOr<std::vector<double>> ScanPointSpacing(const PointCloud& cloud,
                                                     const Neighbourhoods* nb,
                                                     const CancelToken& cancel);

}  // namespace scanprep
