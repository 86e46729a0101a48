// SPDX-License-Identifier: Apache-2.0
#include "core/stages/surface_spikes.h"

#include <algorithm>
#include <atomic>
#include <cmath>

#include "core/base/parallel.h"
#include "core/spatial/ball_points.h"
#include "core/spatial/flattest_neighbours.h"
#include "core/spatial/local_moments.h"

namespace scanprep {
namespace {

// Candidate planes per point: those of its flattest neighbours.
constexpr size_t kCandidates = 8;
// A plane counts when this share of the point's neighbours (and at least kMinSupport) lie within
// the gate of it: a face beside an edge may hold only a few of the ball's points.
constexpr double kMinSupportShare = 0.1;
constexpr size_t kMinSupport = 4;
// The local σ may exceed the scan's by this factor (oblique views), no more (an edge's fits).
constexpr float kLocalNoiseCap = 4.f;
// Supporters lie within this many of the largest local σ allowed, kLocalNoiseCap·σ̂.
constexpr float kGateSigmas = 3.f;
// A point within the gate of a plane that holds at least this share of its neighbours lies on
// the surface; with fewer, near a plane but not surrounded by it.
constexpr double kSurroundedShare = 0.5;

// A plane through `origin`, relative to the point judged (which is at 0).
struct Plane {
  Eigen::Vector3f origin, normal;
  float OffsetOfCentre() const { return std::abs(origin.dot(normal)); }
};

// A candidate plane: its offset from the point judged and its rank by flatness.
struct Candidate {
  float offset;
  size_t rank;
  Plane plane;
};

struct Scratch {
  RadiusMatches matches;
  BallPoints ball;  // the matches' positions relative to the point judged
  std::vector<std::pair<float, uint32_t>> candidates;  // (surface variation, index)
  std::vector<Candidate> nearest_first;
};

struct Judged {
  Plane plane;   // refitted
  float offset;  // of the point from the refitted plane
  float sigma;   // RMS offset of the plane's supporters from it
  float share;   // of the point's neighbours that support it
};

// The plane fitted to the matches that lie within `gate` of `plane` (or, `inside` false, to those
// that do not), with the offset of the point from it.
std::optional<Judged> Refit(const Plane& plane, float gate, bool inside, Scratch& scratch) {
  MomentAccumulator moments;
  const std::vector<float>& offset = scratch.ball.OffsetsFrom(plane.origin, plane.normal);
  for (size_t k = 0; k < offset.size(); ++k) {
    if ((std::abs(offset[k]) <= gate) == inside)
      moments.Add(scratch.ball.at(k).cast<double>(), 1.0);
  }
  if (moments.count() < kMinSupport) return std::nullopt;
  const LocalFrame frame = moments.Solve();
  if (!frame.valid) return std::nullopt;
  return Judged{Plane{frame.centroid.cast<float>(), frame.normal().cast<float>()},
                static_cast<float>(std::abs(frame.centroid.dot(frame.normal()))),
                // A plane fitted to n points leaves them n − 3 degrees of freedom.
                static_cast<float>(std::sqrt(frame.eigenvalues[0] * double(moments.count()) /
                                             double(moments.count() - 3))),
                static_cast<float>(moments.count()) / static_cast<float>(offset.size())};
}

// How many of the matches lie within `gate` of the plane.
size_t Support(const Plane& plane, float gate, Scratch& scratch) {
  const std::vector<float>& offset = scratch.ball.OffsetsFrom(plane.origin, plane.normal);
  uint32_t support = 0;
#pragma omp simd reduction(+ : support)
  for (size_t k = 0; k < offset.size(); ++k) support += std::abs(offset[k]) <= gate;
  return support;
}

// The nearest plane (to point i) that its neighbours support, refitted to its supporters; and,
// when p lies off it, the plane of the rest of the neighbours if p lies nearer that one: beside an
// edge the flattest neighbours may all be of the other face, and p, on its own sparser face, is
// off their plane without being off the surface. Nothing when no candidate is supported.
std::optional<Judged> NearestSupportedPlane(const PointCloud& cloud, size_t i, float gate,
                                            Scratch& scratch) {
  const Eigen::Vector3f p = cloud.point(i);
  scratch.ball.Gather(cloud, scratch.matches, p);
  const size_t support_needed =
      std::max(kMinSupport, static_cast<size_t>(kMinSupportShare * scratch.matches.size()));
  // The candidates nearest first (ties: flattest first), so the first supported one is the
  // answer and the support of the others is never counted.
  auto& nearest_first = scratch.nearest_first;
  nearest_first.clear();
  for (size_t rank = 0; rank < scratch.candidates.size(); ++rank) {
    const uint32_t j = scratch.candidates[rank].second;
    const Plane plane{cloud.point(j) - p, cloud.normal(j)};
    nearest_first.push_back({plane.OffsetOfCentre(), rank, plane});
  }
  std::sort(nearest_first.begin(), nearest_first.end(), [](const auto& a, const auto& b) {
    return a.offset < b.offset || (a.offset == b.offset && a.rank < b.rank);
  });
  std::optional<Plane> nearest;
  for (const Candidate& candidate : nearest_first) {
    if (Support(candidate.plane, gate, scratch) < support_needed) continue;
    nearest = candidate.plane;
    break;
  }
  if (!nearest) return std::nullopt;
  std::optional<Judged> own = Refit(*nearest, gate, true, scratch);
  // Once more within 3 of the supporters' own σ: noise tails and other spikes near the plane
  // would widen σ and tilt the plane.
  if (own) {
    const float scan_sigma = gate / (kGateSigmas * kLocalNoiseCap);
    const float tight =
        kGateSigmas * std::clamp(own->sigma, scan_sigma, kLocalNoiseCap * scan_sigma);
    if (std::optional<Judged> refit = Refit(own->plane, tight, true, scratch)) own = refit;
  }
  if (!own || own->offset <= gate) return own;
  // The rest are a surface only if they lie as close to their plane as a supporter may.
  const std::optional<Judged> rest = Refit(*nearest, gate, false, scratch);
  const bool surface = rest && rest->sigma <= gate / kGateSigmas;
  return surface && rest->offset < own->offset ? rest : own;
}

// The neighbours of i's own scan within `radius`, without i: a spike must not support its own
// plane, nor be judged by another scan's (possibly misregistered) layer.
void OwnScanNeighbours(const PointCloud& cloud, const Neighbourhoods& nb, size_t i, float radius,
                       RadiusMatches& matches) {
  nb.Sample(cloud, i, radius, matches);
  std::erase_if(matches, [&](const auto& match) {
    return match.first == i || cloud.scan[match.first] != cloud.scan[i];
  });
}

}  // namespace

absl::Status JudgeBySurface(const PointCloud& cloud, const Neighbourhoods& nb,
                            const PointMeasures& m, const std::vector<std::optional<double>>& noise,
                            double sigmas, const CancelToken& cancel, std::vector<uint8_t>& verdict,
                            SurfaceSpikeCounts& counts) {
  const size_t n = cloud.size();
  verdict.assign(n, kNotJudged);
  std::atomic<size_t> off_surface{0}, not_judged{0};
  absl::Status status = ParallelFor(n, cancel, [&](size_t begin, size_t end) {
    Scratch scratch;
    size_t local_off = 0, local_not_judged = 0;
    for (size_t i = begin; i < end; ++i) {
      const uint32_t scan = cloud.scan[i];
      if (cloud.removed(i) || !noise[scan]) continue;
      // Where scans overlap the ball is widened once to hold about k of i's own scan, as for
      // the normals.
      float radius = nb.adaptive_radius(i);
      OwnScanNeighbours(cloud, nb, i, radius, scratch.matches);
      if (scratch.matches.size() < nb.k()) {
        radius *= OwnScanWidening(scratch.matches.size(), nb.k());
        OwnScanNeighbours(cloud, nb, i, radius, scratch.matches);
      }
      FlattestNeighbours(cloud, m, scratch.matches, i, kCandidates, scratch.candidates);
      const float scan_sigma = static_cast<float>(*noise[scan]);
      const std::optional<Judged> judged =
          NearestSupportedPlane(cloud, i, kGateSigmas * kLocalNoiseCap * scan_sigma, scratch);
      if (!judged) {
        ++local_not_judged;
        continue;
      }
      // σ of the supporters, not of i's own fit or its neighbours' (a spike is in those).
      const float sigma = std::clamp(judged->sigma, scan_sigma, kLocalNoiseCap * scan_sigma);
      if (judged->offset > sigmas * sigma) {
        verdict[i] = kOffSurface;
        ++local_off;
      } else {
        verdict[i] = judged->share >= kSurroundedShare ? kOnSurface : kNearSurface;
      }
    }
    off_surface += local_off;
    not_judged += local_not_judged;
  });
  counts.off_surface = off_surface;
  counts.not_judged = not_judged;
  return status;
}

}  // namespace scanprep
