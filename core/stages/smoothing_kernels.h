// SPDX-License-Identifier: Apache-2.0
// The new position of one point, by either smoothing method (docs/algorithms.md §11 and the
// project's deviations in docs): the paper's weighted mean (Eq. 8) or the projection onto the plane
// of the point's own side of the surface. Both read only pre-pass positions, so points can be done
// in any order and in parallel.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "core/base/point_cloud.h"
#include "core/base/point_measures.h"
#include "core/spatial/ball_points.h"
#include "core/spatial/neighbourhoods.h"
#include "core/stages/param_table.h"

namespace scanprep {

// kUnfitted: own_side found no plane within the gate of the point (too few points, or none of
// the candidate planes passes near it); the point keeps its position.
enum SmoothingOutcome : uint8_t { kKept = 0, kMoved, kClamped, kRejected, kUnfitted };

// own_side: projection onto the plane of the point's own side; mean: the paper's Eq. (8).
enum class SmoothingMethod { kOwnSide, kMean };
// ball: r_p = max(r_min, d_k), the paper's "k nearest neighbors (typically 20) and the minimal
// radius"; knn: the k-NN list alone (radius d_k, no ball query), half the stage's time, the
// preset `paper`'s. Not the default: own-side planes fitted to 20 points leave more noise on flats
// (0.43× raw where metrology_test holds outliers + smoothing to 0.40×).
enum class SmoothingNeighbourhood { kBall, kKnn };
enum class Influence { kCubic, kGauss, kAverage };
// mean: p' of Eq. (8); blend: each point's own displacement scaled by its weight w_p.
enum class SmoothingMode { kMean, kBlend };
// A move longer than δ is rejected (Eq. 10) or shortened to δ.
enum class SmoothingTolerance { kReject, kClamp };

// The parameters (SmoothingParams() declares them), and what the stage derives per scan.
struct SmoothingSettings {
  SmoothingMethod method = SmoothingMethod::kOwnSide;
  SmoothingNeighbourhood neighbourhood = SmoothingNeighbourhood::kBall;
  float lambda = 0;
  Influence influence = Influence::kCubic;
  SmoothingMode mode = SmoothingMode::kMean;
  SmoothingTolerance tolerance_rule = SmoothingTolerance::kReject;
  Derived<double> noise_mm;      // σ̂ per scan, unless the request fixed it
  Derived<double> tolerance_mm;  // δ per scan (or per point), unless the request fixed it
  int iterations = 0;            // Jacobi passes

  bool own_side() const { return method == SmoothingMethod::kOwnSide; }
  bool knn() const { return neighbourhood == SmoothingNeighbourhood::kKnn; }
  bool blend() const { return mode == SmoothingMode::kBlend; }
  bool clamp() const { return tolerance_rule == SmoothingTolerance::kClamp; }

  // own_side: per scan, the noise σ̂ the gates are set in; a point's local σ lies in
  // [σ̂, kLocalNoiseCap·σ̂].
  std::vector<float> noise;
  // δ per scan: the paper's u, or kMoveSigmas·σ for own_side (then per point, from its local σ)
  // unless the request fixed it (fixed_tolerance).
  std::vector<float> tolerance;
  bool fixed_tolerance = false;
};

// Φ(x) of Fig. 3: 20 % (cubic) and 13.5 % (Gaussian) weight at the rim of the neighbourhood.
float InfluenceAt(Influence kind, float x);

// A point's own fit may be noisier than its scan's median (oblique view, curvature), but never
// counts as more than this many times it: an edge's mixed fit must not widen the gates.
inline constexpr float kLocalNoiseCap = 2.f;
// own_side: a move longer than this many local σ is not noise.
inline constexpr float kMoveSigmas = 3.f;

struct SmoothingScratch {
  RadiusMatches matches;
  BallPoints ball;                                // the matches' positions relative to the point
  std::vector<float> base;                        // w_j·Φ per match
  std::vector<std::pair<float, uint32_t>> seeds;  // (surface variation, point index)
};

struct SmoothingInputs {
  const PointCloud& cloud;
  const Neighbourhoods& nb;
  const PointMeasures& m;
  const SmoothingSettings& s;
};

// Writes the new position of point i to `out` and says what happened to it.
SmoothingOutcome SmoothPoint(const SmoothingInputs& in, size_t i, SmoothingScratch& scratch,
                             Eigen::Vector3f& out);

}  // namespace scanprep
