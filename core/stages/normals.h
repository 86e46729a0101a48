// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstdint>

#include "absl/status/status.h"
#include "core/base/point_cloud.h"
#include "core/base/point_measures.h"
#include "core/spatial/neighbourhoods.h"
#include "core/stages/param_table.h"
#include "core/stages/stage.h"
#include "core/stages/stage_reporter.h"

namespace scanprep {
// Gaussian-weighted PCA normals (paper §2.2, Eq. 4; docs/algorithms.md §6) oriented by Eq. (3) or,
// without sensor poses, along a minimum spanning tree (Eq. 5, §7). Also fills the surface
// variation σ and fit residual of every point into the job's PointMeasures.
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

// The stage: every unremoved point's normal (kNormalInvalid where the fit fails), oriented;
// m.surface_variation and m.fit_rms; then the unit check (WarnIfUnitSuspect), which needs the fits.
absl::Status EstimateNormals(PointCloud& cloud, PointMeasures& m, const Neighbourhoods& nb,
                             const NormalsSettings& params, StageReporter& out);
}  // namespace scanprep
