// SPDX-License-Identifier: Apache-2.0
// The noise σ̂ of each scan, measured from the data: the median RMS residual of its points'
// normal fits (PointMeasures::fit_rms). An edge or a spike inflates a few fits, not the median.
// Used by the surface-spike test and by smoothing, so both judge offsets in the same σ.
#pragma once

#include <cstddef>
#include <optional>
#include <vector>

#include "absl/status/statusor.h"
#include "core/base/cancel.h"
#include "core/base/point_cloud.h"
#include "core/base/point_measures.h"

namespace scanprep {

// Fewer valid normal fits than this in a scan: its noise is not measured.
inline constexpr size_t kMinNoiseSamples = 32;

// σ̂ per scan (`scans` entries), or nothing where fewer than kMinNoiseSamples fits are valid;
// over the points not removed for a reason in `skip`; where other scans lie over a scan, the
// normals stage's own-point measure (PointMeasures::own_scan_noise). In parallel; CANCELLED when
// `cancel` fires.
absl::StatusOr<std::vector<std::optional<double>>> MeasuredScanNoise(const PointCloud& cloud,
                                                                     const PointMeasures& m,
                                                                     size_t scans,
                                                                     const CancelToken& cancel,
                                                                     uint8_t skip = kRemovedMask);

}  // namespace scanprep
