// SPDX-License-Identifier: Apache-2.0
// Optional per-point PCA radius after Mitra, Nguyen & Guibas 2004 — Eq. (1), docs/algorithms.md §3.
#pragma once

#include <cstddef>

#include "core/base/point_cloud.h"
#include "core/spatial/neighbourhoods.h"

namespace scanprep {

struct MitraOptions {
  double c1 = 1, c2 = 1;     // dimensionless constants of Eq. (1)
  double epsilon = 0.05;     // probability that the normal-angle bound fails
  double kappa_min = 1e-3;   // mm⁻¹; a plane would otherwise ask for r → ∞
  double r_max = 0;          // clamp, 5·r_g by default
  uint32_t min_points = 20;  // the ball holds at least this many neighbours
  int max_iterations = 5;
  double tolerance = 0.05;  // stop when r changes by less than 5 %
};

// r(p) = ((c1·σ/√(ε·ρ) + c2·σ²) / κ)^(1/3), iterated from the 15 nearest neighbours: κ from a
// least-squares quadric in the local PCA frame, ρ = |N_r| / (π r²), then r re-evaluated in N_r.
// `scratch` is the caller's reusable query buffer.
float MitraRadius(const PointCloud& cloud, const Neighbourhoods& nb, size_t i, double sigma,
                  const MitraOptions& options, RadiusMatches& scratch);

}  // namespace scanprep
