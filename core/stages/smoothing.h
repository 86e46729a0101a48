// SPDX-License-Identifier: Apache-2.0
#pragma once
#include <string_view>

#include "core/stages/stage.h"
namespace scanprep {
// Edge- and quality-preserving smoothing (paper §3.1, Eqs. 6-10; docs/algorithms.md §11).
StageInfo SmoothingStageInfo();

// The stage's parameters, each name declared here once (its spec and its reader use these).
enum class SmoothingMethod { kOwnSide, kMean };
inline constexpr ChoiceDecl<SmoothingMethod, 2> kSmoothingMethod{"smoothing.method",
                                                                 {"own_side", "mean"}};
enum class Influence { kCubic, kGauss, kAverage };
inline constexpr ChoiceDecl<Influence, 3> kSmoothingInfluence{"smoothing.influence",
                                                              {"cubic", "gauss", "average"}};
enum class SmoothingMode { kMean, kBlend };
inline constexpr ChoiceDecl<SmoothingMode, 2> kSmoothingMode{"smoothing.mode", {"mean", "blend"}};
enum class SmoothingTolerance { kReject, kClamp };
inline constexpr ChoiceDecl<SmoothingTolerance, 2> kSmoothingTolerance{"smoothing.tolerance",
                                                                       {"reject", "clamp"}};
// ball: r_p = max(r_min, d_k), the paper's "k nearest neighbors (typically 20) and the minimal
// radius"; knn: the k-NN list alone (radius d_k, no ball query), half the stage's time, the
// preset `paper`'s. Not the default: own-side planes fitted to 20 points leave more noise on flats
// (0.43× raw where metrology_test holds outliers + smoothing to 0.40×).
enum class SmoothingNeighbourhood { kBall, kKnn };
inline constexpr ChoiceDecl<SmoothingNeighbourhood, 2> kSmoothingNeighbourhood{
    "smoothing.neighbourhood", {"ball", "knn"}};
inline constexpr std::string_view kSmoothingLambda = "smoothing.lambda";
inline constexpr double kDefaultSmoothingLambda = 0.5;
inline constexpr std::string_view kSmoothingNoise = "smoothing.noise_mm";
inline constexpr std::string_view kSmoothingToleranceMm = "smoothing.tolerance_mm";
inline constexpr std::string_view kSmoothingIterations = "smoothing.iterations";
}  // namespace scanprep
