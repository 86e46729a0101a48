// SPDX-License-Identifier: Apache-2.0
#include "core/stages/pair_matches.h"

#include <algorithm>
#include <cmath>
#include <mutex>
#include <utility>

#include "core/base/parallel.h"
#include "core/base/per_scan_values.h"
#include "core/base/status_macros.h"
#include "core/stages/scan_spacing.h"

namespace scanprep {
namespace {

// Whether a fixed scan's point offers a plane: measured, not a spike, not on an edge (where its
// plane is the wrong one for half the points near it).
bool OffersPlane(const PointCloud& cloud, uint32_t j) {
  return (cloud.flags[j] & (kRemovedOutlier | kNormalInvalid | kEdge)) == 0;
}

// How far p_m lies from fixed point j along j's tangent plane. The partner is chosen, and held
// to its reach, by this, never by the 3-D distance: that one includes the very offset along the
// normal being measured, so choosing or cutting by it keeps the points that lie nearer the
// fixed surface and pulls every residual toward 0 (20 µm along z read as 17 µm, and as 4 µm with
// a reach of 0.7 spacings, at 1 M points and σ = 10-20 µm).
float TangentialDistance(const PointCloud& cloud, uint32_t j, size_t i) {
  const Eigen::Vector3f r = cloud.point(i) - cloud.point(j);
  const Eigen::Vector3f n = cloud.normal(j);
  return (r - n * n.dot(r)).norm();
}

// Fixed point j's local plane: the mean position and the mean normal (each turned to j's side)
// of j and its own scan's k-NN neighbours that offer a plane. p_j alone carries its full noise,
// and the choice of j is not independent of it (the candidates are p_m's 3-D nearest, which
// favour points displaced toward p_m); and a single point's normal is noisy enough (a few
// degrees at 1 M points) that, where one face of the overlap holds few points, the noise of the
// many others' normals dilutes that face's direction and the estimate along it reads low
// (errors in variables: 20 µm along x read as 13.5 µm). The means cut both by the
// neighbourhood's size.
struct Plane {
  Eigen::Vector3f normal;
  float offset;  // normal·(mean − p_j)
};
Plane LocalPlane(const PointCloud& cloud, const Neighbourhoods& nb, uint32_t j) {
  const Eigen::Vector3f pj = cloud.point(j), nj = cloud.normal(j);
  Eigen::Vector3f offset = Eigen::Vector3f::Zero(), normal = nj;
  int count = 1;  // j itself, at offset 0
  for (const uint32_t l : nb.knn(j)) {
    if (cloud.scan[l] != cloud.scan[j] || !OffersPlane(cloud, l)) continue;
    offset += cloud.point(l) - pj;
    const Eigen::Vector3f nl = cloud.normal(l);
    normal += nl.dot(nj) < 0 ? -nl : nl;
    ++count;
  }
  normal.normalize();
  return {normal, normal.dot(offset) / static_cast<float>(count)};
}

// A match whose moving point's normal and fixed plane's normal are further apart than this
// (cos 18°) is two faces, not one seen twice: a point beside an edge (most are not flagged EDGE)
// whose fit blends both faces. Such matches gave the box's +x/−x pair an rz its faces do not
// see: 3-4 µm off a right pose at a standard error of 1 µm, the objective's minimum there; left
// out, that rz is unconstrained, as its geometry says. A narrow window, measured on the
// simulated parts and the real scans: at cos 0.9 the rz comes back (5.7 µm off a right pose), at
// 0.96 the Happy Buddha's 24° scan ends 0.3 % worse, at 0.98 three of its scans do.
constexpr float kMinNormalCosine = 0.95f;

}  // namespace

absl::StatusOr<std::map<uint32_t, std::vector<Correspondence>>> FindCorrespondences(
    const PointCloud& cloud, const PointMeasures& m, const Neighbourhoods& nb,
    const PairSearch& search, std::span<const uint32_t> points, const CancelToken& cancel) {
  const std::vector<float>& reach = search.reach;
  std::mutex mu;
  std::map<size_t, std::vector<Correspondence>> blocks;
  SCANPREP_RETURN_IF_ERROR(ParallelFor(points.size(), cancel, [&](size_t begin, size_t end) {
    std::vector<Correspondence> found;
    std::vector<std::pair<uint32_t, float>> best;  // per lower scan met: (point, tangential)
    for (size_t at = begin; at < end; ++at) {
      const uint32_t i = points[at];
      const uint32_t s = cloud.scan[i];
      if (cloud.flags[i] & (kRemovedOutlier | kNormalInvalid)) continue;
      best.clear();
      const KnnList list = nb.knn(i);
      for (size_t m = 0; m < list.size(); ++m) {
        const uint32_t j = list[m];
        const uint32_t f = cloud.scan[j];
        if (f >= s || !OffersPlane(cloud, j)) continue;
        const float tangential = TangentialDistance(cloud, j, i);
        if (tangential > reach[f]) continue;
        auto it = std::find_if(best.begin(), best.end(),
                               [&](const auto& b) { return cloud.scan[b.first] == f; });
        if (it == best.end()) {
          best.emplace_back(j, tangential);
        } else if (tangential < it->second) {
          *it = {j, tangential};
        }
      }
      for (const auto& [j, tangential] : best) {
        const Plane plane = LocalPlane(cloud, nb, j);
        if (std::abs(plane.normal.dot(cloud.normal(i))) < kMinNormalCosine) continue;
        found.push_back({i, j, plane.normal, plane.offset, std::hypot(m.fit_rms[i], m.fit_rms[j])});
      }
    }
    std::lock_guard lock(mu);
    blocks.emplace(begin, std::move(found));
  }));
  // Each fixed scan's list reserved at its exact size and each block freed once copied: the
  // matches are held about once, not up to three times as vectors growing by doubling would.
  std::map<uint32_t, std::vector<Correspondence>> by_fixed;
  std::map<uint32_t, size_t> count;
  for (const auto& [begin, found] : blocks) {
    for (const Correspondence& c : found) ++count[cloud.scan[c.fixed]];
  }
  for (const auto& [fixed, n] : count) by_fixed[fixed].reserve(n);
  for (auto& [begin, found] : blocks) {
    for (const Correspondence& c : found) by_fixed[cloud.scan[c.fixed]].push_back(c);
    std::vector<Correspondence>().swap(found);
  }
  return by_fixed;
}

std::vector<std::vector<uint32_t>> PointsPerScan(const PointCloud& cloud) {
  std::vector<std::vector<uint32_t>> points(cloud.scans.size());
  const std::vector<size_t> count = ScanPointCounts(cloud);
  for (size_t s = 0; s < points.size(); ++s) points[s].reserve(count[s]);
  for (uint32_t i = 0; i < cloud.size(); ++i) points[cloud.scan[i]].push_back(i);
  return points;
}

absl::StatusOr<PairSearch> MakePairSearch(const PointCloud& cloud, const Neighbourhoods& nb,
                                          double max_pair_distance, const CancelToken& cancel) {
  PairSearch search;
  SCANPREP_ASSIGN_OR_RETURN(search.spacing, ScanPointSpacing(cloud, &nb, cancel));
  const size_t scans = cloud.scans.size();
  search.reach.resize(scans);
  for (size_t s = 0; s < scans; ++s) {
    const double ds = cloud.kind == ScannerKind::kLine ? cloud.scans[s].scanline_spacing : 0.0;
    search.spacing[s] = std::max(search.spacing[s], ds);
    search.reach[s] = static_cast<float>(max_pair_distance * search.spacing[s]);
  }
  return search;
}

}  // namespace scanprep
