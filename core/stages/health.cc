// SPDX-License-Identifier: Apache-2.0
// Scanner health from what the pipeline measured anyway, before smoothing moves a point: per scan
// the noise σ̂ of its own normal fits, the shares the outlier and merge stages removed and the
// viewing angles; per overlapping pair the residuals of the moving scan against the fixed scan's
// planes and the misalignment they imply (pair_misalignment.h). The pairs come from the shared
// k-NN graph: a point's nearest neighbour of a lower-numbered scan, no new search. O(n·k).
#include "core/stages/health.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <mutex>
#include <numbers>
#include <span>
#include <tuple>
#include <utility>

#include "core/base/parallel.h"
#include "core/base/per_scan_values.h"
#include "core/base/status_macros.h"
#include "core/spatial/view_geometry.h"
#include "core/stages/pair_misalignment.h"
#include "core/stages/scan_noise.h"
#include "core/stages/scan_spacing.h"
#include "core/stages/stage_context.h"
#include "core/stages/stage_names.h"

namespace scanprep {
namespace {

// The 10th, 50th and 90th percentile of `v` (reordered), by selection.
std::array<double, 3> Deciles(std::vector<float>& v) {
  std::array<double, 3> out{};
  constexpr std::array<double, 3> kAt = {0.1, 0.5, 0.9};
  for (size_t q = 0; q < kAt.size(); ++q) {
    auto at = v.begin() + static_cast<std::ptrdiff_t>(kAt[q] * double(v.size() - 1));
    std::nth_element(v.begin(), at, v.end());
    out[q] = *at;
  }
  return out;
}

// count / of, 0 for none; in double, so a client's absurd count cannot wrap a sum.
double Fraction(double count, double of) { return of > 0 ? count / of : 0.0; }

std::optional<double> ShareOf(uint64_t count, uint64_t points, bool known) {
  if (!known) return std::nullopt;
  return Fraction(double(count), double(points));
}

// `noise`: each scan's σ̂ (MeasuredScanNoise).
absl::StatusOr<std::vector<ScanHealth>> ScanHealths(const PointCloud& cloud,
                                                    const std::vector<std::optional<double>>& noise,
                                                    const RemovalStagesRun& ran,
                                                    const CancelToken& cancel) {
  const size_t scans = cloud.scans.size();
  std::vector<uint64_t> points(scans), outliers(scans), merged(scans);
  for (size_t i = 0; i < cloud.size(); ++i) {
    const uint32_t s = cloud.scan[i];
    ++points[s];
    outliers[s] += (cloud.flags[i] & kRemovedOutlier) != 0;
    merged[s] += (cloud.flags[i] & kRemovedMerge) != 0;
  }
  // The sensor's view of every surface point it measured, the merged-away ones included; per
  // scan in any order, as only their deciles are reported.
  SCANPREP_ASSIGN_OR_RETURN(
      std::vector<std::vector<float>> angles,
      ValuesPerScan(cloud, cloud.size(), cancel, [&](size_t i, const auto& add) {
        if (cloud.flags[i] & (kRemovedOutlier | kNormalInvalid)) return;
        const uint32_t s = cloud.scan[i];
        const Eigen::Vector3d p = cloud.point(i).cast<double>();
        if (const auto toward = TowardCamera(cloud.scans[s], p)) {
          const double angle = ViewAngle(cloud.normal(i).cast<double>(), *toward);
          add(s, static_cast<float>(angle * 180 / std::numbers::pi));
        }
      }));
  std::vector<ScanHealth> out(scans);
  for (size_t s = 0; s < scans; ++s) {
    ScanHealth& h = out[s];
    const ScanMeta& meta = cloud.scans[s];
    h.scan = static_cast<uint32_t>(s);
    h.points = points[s];
    h.scan_id = meta.id;
    h.sensor_id = meta.sensor_id;
    h.noise_mm = noise[s];
    if (noise[s] && meta.uncertainty_stated && meta.uncertainty > 0) {
      h.noise_to_uncertainty = *noise[s] / meta.uncertainty;
    }
    h.outlier_share = ShareOf(outliers[s], h.points, ran.outliers);
    h.merged_share = ShareOf(merged[s], h.points, ran.correction);
    // Of every point the sensor delivered: the unmeasured ones never entered the pipeline.
    const double invalid = double(meta.points_invalid);
    h.invalid_share = Fraction(invalid, double(h.points) + invalid);
    if (!angles[s].empty()) h.viewing_angle_deg = Deciles(angles[s]);
  }
  return out;
}

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

// The correspondences of the moving scan whose points are `points`, per fixed scan (a lower-
// numbered one): each point with a normal fit, not removed as an outlier, with its partner in
// every lower-numbered scan: among its k-NN neighbours of that scan within `reach` and offering a
// plane, the one nearest along its tangent plane. In point order (blocks kept by their start, so
// the sums do not depend on the threads).
absl::StatusOr<std::map<uint32_t, std::vector<Correspondence>>> FindCorrespondences(
    const PointCloud& cloud, const PointMeasures& m, const Neighbourhoods& nb,
    const std::vector<float>& reach, const std::vector<float>& least_noise,
    std::span<const uint32_t> points, const CancelToken& cancel) {
  // A point's noise: its fit's residual, but never below its scan's median fit. A fit far below it
  // stood on points nearly in a line (a face seen at a grazing angle, a scanline or two across
  // it): its residual says nothing about the noise and its normal little about the face, and
  // weighted by the inverse of such a residual a few thousand of them outweighed the whole overlap
  // and held a translation at 0 with a standard error of 0.1 µm.
  const auto noise = [&](uint32_t i) { return std::max(m.fit_rms[i], least_noise[cloud.scan[i]]); };
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
        found.push_back({i, j, plane.normal, plane.offset, std::hypot(noise(i), noise(j))});
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

// The points of each scan, in index order (a counting sort).
std::vector<std::vector<uint32_t>> PointsPerScan(const PointCloud& cloud) {
  std::vector<std::vector<uint32_t>> points(cloud.scans.size());
  const std::vector<size_t> count = ScanPointCounts(cloud);
  for (size_t s = 0; s < points.size(); ++s) points[s].reserve(count[s]);
  for (uint32_t i = 0; i < cloud.size(); ++i) points[cloud.scan[i]].push_back(i);
  return points;
}

absl::StatusOr<std::vector<PairHealth>> PairHealths(const PointCloud& cloud, const PointMeasures& m,
                                                    const Neighbourhoods& nb,
                                                    const std::vector<std::optional<double>>& noise,
                                                    const HealthSettings& params,
                                                    const CancelToken& cancel) {
  const MisalignmentSettings settings{.min_points = params.min_overlap_points,
                                      .max_standard_error = params.max_standard_error};
  const double spacings = params.max_pair_distance;
  std::vector<PairHealth> out;
  if (cloud.scans.size() < 2) return out;
  // A scan's spacing: the coarser of Δp and, for a line scanner, Δs.
  SCANPREP_ASSIGN_OR_RETURN(const std::vector<double> spacing,
                            ScanPointSpacing(cloud, &nb, cancel));
  std::vector<float> reach(cloud.scans.size()), least_noise(cloud.scans.size());
  for (size_t s = 0; s < least_noise.size(); ++s) {
    least_noise[s] = static_cast<float>(noise[s].value_or(0));
  }
  for (size_t s = 0; s < reach.size(); ++s) {
    const double ds = cloud.kind == ScannerKind::kLine ? cloud.scans[s].scanline_spacing : 0.0;
    reach[s] = static_cast<float>(spacings * std::max(spacing[s], ds));
  }
  // One moving scan at a time: the correspondences held at once are one scan's (up to k a point
  // where k scans overlap), not the job's.
  const std::vector<std::vector<uint32_t>> points = PointsPerScan(cloud);
  for (uint32_t moving = 1; moving < points.size(); ++moving) {
    SCANPREP_ASSIGN_OR_RETURN(auto by_fixed, FindCorrespondences(cloud, m, nb, reach, least_noise,
                                                                 points[moving], cancel));
    for (const auto& [fixed, matches] : by_fixed) {
      SCANPREP_RETURN_IF_ERROR(cancel.Check());
      SCANPREP_ASSIGN_OR_RETURN(
          PairHealth pair, EstimatePairHealth(cloud, fixed, moving, matches, settings, cancel));
      out.push_back(std::move(pair));
    }
  }
  std::sort(out.begin(), out.end(), [](const PairHealth& a, const PairHealth& b) {
    return std::pair(a.fixed, a.moving) < std::pair(b.fixed, b.moving);
  });
  return out;
}

class HealthStage : public Stage {
 public:
  absl::Status Run(StageContext& ctx) override {
    SCANPREP_ASSIGN_OR_RETURN(const Neighbourhoods* nb, ctx.neighbourhoods());
    const RemovalStagesRun ran{.outliers = ctx.Ran(stage_names::kOutliers),
                               .correction = ctx.Ran(stage_names::kCorrection)};
    SCANPREP_ASSIGN_OR_RETURN(HealthReport health,
                              MeasureHealth(ctx.cloud(), ctx.measures(), *nb,
                                            ctx.Settings(HealthParams()), ran, ctx.out()));
    ctx.SetHealth(std::move(health));
    return absl::OkStatus();
  }
};

// Keeps the kMaxReportedPairs pairs with the most overlap points, in (fixed, moving) order, and
// returns how many it left out: 64 scans that all overlap are 2,016 pairs, and the report and the
// per-sensor series would grow with the square of the scans.
size_t KeepLargestOverlaps(std::vector<PairHealth>& pairs) {
  if (pairs.size() <= kMaxReportedPairs) return 0;
  const size_t left_out = pairs.size() - kMaxReportedPairs;
  const auto by_overlap = [](const PairHealth& a, const PairHealth& b) {
    return std::tie(b.overlap_points, a.fixed, a.moving) <
           std::tie(a.overlap_points, b.fixed, b.moving);
  };
  std::nth_element(pairs.begin(), pairs.begin() + kMaxReportedPairs, pairs.end(), by_overlap);
  pairs.resize(kMaxReportedPairs);
  std::sort(pairs.begin(), pairs.end(), [](const PairHealth& a, const PairHealth& b) {
    return std::tie(a.fixed, a.moving) < std::tie(b.fixed, b.moving);
  });
  return left_out;
}

}  // namespace

absl::StatusOr<HealthReport> MeasureHealth(const PointCloud& cloud, const PointMeasures& m,
                                           const Neighbourhoods& nb, const HealthSettings& settings,
                                           const RemovalStagesRun& ran, StageReporter& out) {
  if (m.fit_rms.size() != cloud.size()) {
    return absl::InternalError("health: the normals stage left no fit residuals");
  }
  // The sensor's noise over every point it measured well: the merged-away ones included (a scan
  // another sees better may lose most of its points to the merge).
  SCANPREP_ASSIGN_OR_RETURN(
      const std::vector<std::optional<double>> noise,
      MeasuredScanNoise(cloud, m, cloud.scans.size(), out.cancel(), kRemovedOutlier));
  HealthReport health;
  SCANPREP_ASSIGN_OR_RETURN(health.pairs, PairHealths(cloud, m, nb, noise, settings, out.cancel()));
  SCANPREP_ASSIGN_OR_RETURN(health.scans, ScanHealths(cloud, noise, ran, out.cancel()));
  out.Record("health.pairs", static_cast<double>(health.pairs.size()));
  if (const size_t left_out = KeepLargestOverlaps(health.pairs); left_out > 0) {
    out.Record("health.pairs_left_out", static_cast<double>(left_out));
  }
  return health;
}

const ParamTable<HealthSettings>& HealthParams() {
  using S = HealthSettings;
  static const ParamTable<S> table = {
      param::Integer(&S::min_overlap_points, "health.min_overlap_points", 1000, Closed(6, 1e4),
                     "fewer overlap points than this: a pair's misalignment is not solved"),
      param::Real(&S::max_standard_error, "health.max_standard_error", 0.05, Open(0, 1),
                  "a misalignment component whose standard error exceeds this share of the "
                  "pair's residual spread is unconstrained (flat or narrow overlaps)"),
      param::Real(&S::max_pair_distance, "health.max_pair_distance", 2, LeftOpen(0, 100),
                  "farthest a fixed scan's point may lie from a moving one to give it a plane, "
                  "in the fixed scan's spacings (the coarser of Δp and Δs)"),
  };
  return table;
}

StageInfo HealthStageInfo() {
  return {
      .name = std::string(stage_names::kHealth),
      .summary =
          "scanner health: per scan noise σ̂, removed shares and viewing angles; per "
          "overlapping pair point-to-plane residuals and rigid misalignment",
      .params = HealthParams().Specs(),
      .make = [] { return std::make_unique<HealthStage>(); },
      .prerequisites =
          [](const ParamOverrides&) {
            return stage_names::List(
                {stage_names::kNeighbourhoods, stage_names::kNormals, stage_names::kMeasures});
          },
      .work_per_point = 1,
      .cost_weight = 0.35,
  };
}

}  // namespace scanprep
