// SPDX-License-Identifier: Apache-2.0
// Spikes that stand just off the surface. A triangulation spike displaced along the viewing ray by
// a few noise σ has a nearest neighbour as close as any grid point, so no distance rule (d_1,
// LoOP) can see it; what gives it away is its offset from the surface around it. A point is a
// spike when it lies more than `sigmas` local σ off every plane that its own scan's neighbours
// support: the candidate planes are those of its flattest neighbours, so beside an edge the
// plane of its own face still counts and edge points are not mistaken for spikes.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "absl/status/status.h"
#include "core/base/cancel.h"
#include "core/base/point_cloud.h"
#include "core/base/point_measures.h"
#include "core/spatial/neighbourhoods.h"

namespace scanprep {

// kNotJudged: removed, of a scan without measured noise, or no plane its neighbours support.
// kOnSurface: within the gate of a plane that at least half its neighbours support; kNearSurface:
// of one that fewer support (not a spike, but not vouched for either).
enum SurfaceVerdict : uint8_t { kNotJudged = 0, kOnSurface, kNearSurface, kOffSurface };

struct SurfaceSpikeCounts {
  size_t off_surface = 0;
  size_t not_judged = 0;  // unremoved points of measured scans that no supported plane judged
};

// The verdict for every point of a scan with a measured noise σ̂ (`noise`, per scan): off the
// surface when it lies more than sigmas·σ_i from the nearest supported plane, σ_i = the RMS
// offset of that plane's supporters clamped to [σ̂, 2σ̂]. Needs normals and PointMeasures.
absl::Status JudgeBySurface(const PointCloud& cloud, const Neighbourhoods& nb,
                            const PointMeasures& m, const std::vector<std::optional<double>>& noise,
                            double sigmas, const CancelToken& cancel, std::vector<uint8_t>& verdict,
                            SurfaceSpikeCounts& counts);

}  // namespace scanprep
