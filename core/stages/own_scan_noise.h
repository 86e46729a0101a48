// SPDX-License-Identifier: Apache-2.0
// σ̂ of a scan from its own points at its own spacing, where other scans lie over it. The normals
// stage's fits take the own-scan share of a sampled ball: under N fully overlapping scans about
// 63/N points, so their residuals read low (a plane of σ = 10 µm in 8 scans read 7.8 µm, in 200
// scans 4e-9 mm) and the σ̂ that smoothing, the spike test, the edge decision and health judge by
// with them. For a scan whose points' k-NN lists are mostly other scans', a sample of its points
// is fitted on the nearest points of that scan alone, as the normals stage fits a scan on its own.
#pragma once

#include <optional>
#include <vector>

#include "absl/status/statusor.h"
#include "core/base/cancel.h"
#include "core/base/point_cloud.h"
#include "core/spatial/neighbourhoods.h"

namespace scanprep {

// Below this share of own-scan points in its sample's k-NN lists, a scan's σ̂ comes from fits of
// its own points: under three fully overlapping scans a normals ball still holds about 21 of its
// points, the k + 1 its residual's median is calibrated for, and σ̂ reads within 1 % of the scan
// alone; from four on (a share of 1/4, 16 points) within 3 %, from five on own fits take over. A
// higher share would also move real overlaps that the normals fits measure well (the Happy Buddha
// scans, shares 0.3-0.4, where own fits read within 4 % of the scans alone, not 1 %).
inline constexpr double kOwnShareForNormalsFits = 0.25;

// Per scan: the median RMS residual of own-point fits (the normals stage's ball, r_p = max(r_min,
// d_k of the scan's own points), Gaussian h = `h_factor`·r_p, at most
// kSamplePointsPerNeighbour·(k + 1) of them, evenly over the ball) over a strided sample of the
// scan's points, for the scans below kOwnShareForNormalsFits; nothing for the others, nor where
// fewer than kMinNoiseSamples fits were valid. CANCELLED when `cancel` fires.
absl::StatusOr<std::vector<std::optional<double>>> OwnScanNoise(const PointCloud& cloud,
                                                                const Neighbourhoods& nb,
                                                                double h_factor,
                                                                const CancelToken& cancel);

}  // namespace scanprep
