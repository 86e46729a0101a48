// SPDX-License-Identifier: Apache-2.0
#pragma once
#include <string_view>

#include "core/stages/stage.h"
namespace scanprep {
// Gaussian-weighted PCA normals (paper §2.2, Eq. 4; docs/algorithms.md §6) oriented by Eq. (3) or,
// without sensor poses, along a minimum spanning tree (Eq. 5, §7). Also fills the surface
// variation σ of every point into StageContext::measures().
StageInfo NormalsStageInfo();

// The stage's parameters, each name declared here once (its spec and its reader use these).
// adaptive: r_p = max(r_min, d_k), the paper's ball; knn: r = d_k, the k-NN list alone (no ball
// query; the paper's "k nearest neighbors (typically 20)"), the preset `paper`'s; mitra: below.
enum class NormalsRadiusMode { kAdaptive, kMitra, kKnn };
inline constexpr ChoiceDecl<NormalsRadiusMode, 3> kNormalsRadiusMode{"normals.radius_mode",
                                                                     {"adaptive", "mitra", "knn"}};
inline constexpr std::string_view kNormalsGaussianHFactor = "normals.gaussian_h_factor";
inline constexpr std::string_view kNormalsOrientationK = "normals.orientation_k";
inline constexpr std::string_view kNormalsMitraC1 = "normals.mitra_c1";
inline constexpr std::string_view kNormalsMitraC2 = "normals.mitra_c2";
inline constexpr std::string_view kNormalsMitraEpsilon = "normals.mitra_epsilon";
inline constexpr std::string_view kNormalsMitraSigma = "normals.mitra_sigma_mm";
inline constexpr std::string_view kNormalsMitraMaxRadius = "normals.mitra_max_radius_mm";
}  // namespace scanprep
