// SPDX-License-Identifier: Apache-2.0
#include "core/stages/smoothing_kernels.h"

#include <algorithm>
#include <cmath>
#include <optional>

#include "core/spatial/flattest_neighbours.h"
#include "core/spatial/local_moments.h"

namespace scanprep {
namespace {

// Candidate planes tried per point: its own and those of its flattest neighbours.
constexpr size_t kSeeds = 8;
// Reweighted fits after the best candidate plane is chosen.
constexpr int kRefits = 2;
// A plane needs this many points within the gate to be trusted.
constexpr size_t kMinInliers = 6;

float Eq6Weight(const SmoothingInputs& in, uint32_t j) {  // 1 = well viewed and flat
  return in.s.lambda * in.m.quality[j] + (1.f - in.s.lambda) * (1.f - in.m.curvature[j]);
}

// Fills scratch.base with w_j·Φ(x_j) for every match of point i (Eqs. 6 and 9).
void BaseWeights(const SmoothingInputs& in, float r_p, SmoothingScratch& scratch) {
  scratch.base.resize(scratch.matches.size());
  for (size_t k = 0; k < scratch.matches.size(); ++k) {
    const auto [j, d2] = scratch.matches[k];
    const float x = std::min(1.f, std::sqrt(d2) / r_p);
    scratch.base[k] = Eq6Weight(in, j) * InfluenceAt(in.s.influence, x);
  }
}

// Applies Eq. (10) to a move of point i from p by `step`.
SmoothingOutcome Limit(const SmoothingSettings& s, float delta, const Eigen::Vector3f& p,
                       Eigen::Vector3f step, Eigen::Vector3f& out) {
  const float len = step.norm();
  if (len == 0) return kKept;
  SmoothingOutcome outcome = kMoved;
  if (len > delta) {
    if (!s.clamp()) return kRejected;
    step *= delta / len;
    outcome = kClamped;
  }
  out = p + step;
  return outcome;
}

// The paper's Eq. (8): the weighted mean of the neighbourhood, δ = u.
SmoothingOutcome Mean(const SmoothingInputs& in, size_t i, const Eigen::Vector3f& p,
                      SmoothingScratch& scratch, Eigen::Vector3f& out) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  double total = 0;
  for (size_t k = 0; k < scratch.matches.size(); ++k) {
    sum += double(scratch.base[k]) * in.cloud.point(scratch.matches[k].first).cast<double>();
    total += scratch.base[k];
  }
  if (total < 1e-12) return kKept;
  Eigen::Vector3d target = sum / total;
  const Eigen::Vector3d p0 = p.cast<double>();
  if (in.s.blend()) target = p0 + double(Eq6Weight(in, static_cast<uint32_t>(i))) * (target - p0);
  return Limit(in.s, in.s.tolerance[in.cloud.scan[i]], p, (target - p0).cast<float>(), out);
}

// A plane through `origin`, relative to the point being smoothed (which is at 0).
struct Plane {
  Eigen::Vector3f origin, normal;
  float OffsetOfCentre() const { return -origin.dot(normal); }
};

// Summed base weight of the matches within `gate` of the plane.
float Support(SmoothingScratch& scratch, const Plane& plane, float gate) {
  const std::vector<float>& offset = scratch.ball.OffsetsFrom(plane.origin, plane.normal);
  const float* base = scratch.base.data();
  float support = 0;
#pragma omp simd reduction(+ : support)
  for (size_t k = 0; k < offset.size(); ++k) support += std::abs(offset[k]) <= gate ? base[k] : 0.f;
  return support;
}

// The candidate plane (a point's position and normal) that passes within the gate of p and holds
// the most weight: near an edge, the plane of p's own side.
std::optional<Plane> BestSeed(const SmoothingInputs& in, size_t i, const Eigen::Vector3f& p,
                              float gate, SmoothingScratch& scratch) {
  FlattestNeighbours(in.cloud, in.m, scratch.matches, i, kSeeds - 1, scratch.seeds);
  if (!(in.cloud.flags[i] & kNormalInvalid)) scratch.seeds.emplace_back(0.f, i);
  // A plane that holds every match's weight cannot be beaten (a later one must hold more): on a
  // flat face the first, flattest, seed usually does, and the others are not counted. Summed by
  // the same loop, so "every" compares equal.
  const float everything =
      Support(scratch, Plane{Eigen::Vector3f::Zero(), Eigen::Vector3f::UnitZ()}, HUGE_VALF);
  std::optional<Plane> best;
  float best_support = 0;
  for (const auto& [variation, j] : scratch.seeds) {
    const Plane plane{in.cloud.point(j) - p, in.cloud.normal(j)};
    if (std::abs(plane.OffsetOfCentre()) > gate) continue;
    const float support = Support(scratch, plane, gate);
    if (support > best_support) best_support = support, best = plane;
    if (best_support >= everything) break;
  }
  return best;
}

// Projects p onto the plane of its own side of the surface: the best candidate plane, refitted
// to the points within the gate with weights base·e^{−½(offset/σ)²}. Neighbours across an edge
// lie off that plane and drop out, so the edge is not rounded: it gets sharper.
SmoothingOutcome OwnSide(const SmoothingInputs& in, size_t i, const Eigen::Vector3f& p,
                         SmoothingScratch& scratch, Eigen::Vector3f& out) {
  const uint32_t scan = in.cloud.scan[i];
  const float scan_noise = in.s.noise[scan];
  if (!(scan_noise > 0)) return kKept;
  const float own = in.cloud.flags[i] & kNormalInvalid ? 0.f : in.m.fit_rms[i];
  const float sigma = std::clamp(own, scan_noise, kLocalNoiseCap * scan_noise);
  const float gate = kMoveSigmas * sigma;
  scratch.ball.Gather(in.cloud, scratch.matches, p);
  std::optional<Plane> plane = BestSeed(in, i, p, gate, scratch);
  if (!plane) return kUnfitted;
  const float inv_two_s2 = 1.f / (2 * sigma * sigma);
  for (int fit = 0; fit < kRefits; ++fit) {
    MomentAccumulator moments;
    const std::vector<float>& offset = scratch.ball.OffsetsFrom(plane->origin, plane->normal);
    for (size_t k = 0; k < offset.size(); ++k) {
      if (std::abs(offset[k]) > gate || !(scratch.base[k] > 0)) continue;
      moments.Add(scratch.ball.at(k).cast<double>(),
                  scratch.base[k] * std::exp(-offset[k] * offset[k] * inv_two_s2));
    }
    const LocalFrame frame = moments.Solve();
    if (!frame.valid || moments.count() < kMinInliers) return kUnfitted;
    plane = Plane{frame.centroid.cast<float>(), frame.normal().cast<float>()};
  }
  const float delta = in.s.fixed_tolerance ? in.s.tolerance[scan] : kMoveSigmas * sigma;
  return Limit(in.s, delta, p, -plane->OffsetOfCentre() * plane->normal, out);
}

}  // namespace

float InfluenceAt(Influence kind, float x) {
  switch (kind) {
    case Influence::kCubic:
      return 1.f - 0.8f * x * x * x;
    case Influence::kGauss:
      return std::exp(-2.f * x * x);
    case Influence::kAverage:
      return 1.f;
  }
  return 1.f;
}

SmoothingOutcome SmoothPoint(const SmoothingInputs& in, size_t i, SmoothingScratch& scratch,
                             Eigen::Vector3f& out) {
  const Eigen::Vector3f p = in.cloud.point(i);
  out = p;
  if (in.cloud.removed(i)) return kKept;
  const float r_p = in.s.knn() ? in.nb.dk(i) : in.nb.adaptive_radius(i);
  if (!(r_p > 0)) return kKept;
  // Includes i itself (x = 0, Φ = 1). The own-side fit also takes the points merging removed:
  // they are measurements of the same surface, only worse viewed (Eq. 6 weighs them so), and
  // without them the merged layer is smoothed from a third of the data where three scans overlap.
  const uint8_t skip = in.s.own_side() ? kRemovedOutlier | kRemovedSimplify : kRemovedMask;
  in.nb.Sample(in.cloud, i, r_p, scratch.matches, skip);
  BaseWeights(in, r_p, scratch);
  return in.s.own_side() ? OwnSide(in, i, p, scratch, out) : Mean(in, i, p, scratch, out);
}

}  // namespace scanprep
