// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstdint>

#include "core/stages/param_table.h"
#include "core/stages/stage.h"
namespace scanprep {
// Gaussian-weighted PCA normals (paper §2.2, Eq. 4; docs/algorithms.md §6) oriented by Eq. (3) or,
// without sensor poses, along a minimum spanning tree (Eq. 5, §7). Also fills the surface
// variation σ of every point into StageContext::measures().
StageInfo NormalsStageInfo();

// adaptive: r_p = max(r_min, d_k), the paper's ball; knn: r = d_k, the k-NN list alone (no ball
// query; the paper's "k nearest neighbors (typically 20)"), the preset `paper`'s; mitra: the
// radius of Mitra et al.'s Eq. (1).
enum class NormalsRadiusMode { kAdaptive, kMitra, kKnn };

// The parameters (NormalsParams() declares them).
struct NormalsSettings {
  NormalsRadiusMode radius_mode = NormalsRadiusMode::kAdaptive;
  double h_factor = 0;              // Gaussian width h as a fraction of the ball radius
  Derived<uint32_t> orientation_k;  // min(10, neighbourhoods.k) unless set
  double mitra_c1 = 0, mitra_c2 = 0, mitra_epsilon = 0;  // Eq. (1)
  Derived<double> mitra_sigma_mm;                        // σ_n for every scan, else each scan's u
  Derived<double> mitra_max_radius_mm;                   // 5·r_g unless set

  bool mitra() const { return radius_mode == NormalsRadiusMode::kMitra; }
};
const ParamTable<NormalsSettings>& NormalsParams();
}  // namespace scanprep
