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
#include "core/stages/pair_matches.h"
#include "core/stages/pair_misalignment.h"
#include "core/stages/scan_noise.h"
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

class HealthStage : public Stage {
 public:
  absl::Status Run(StageContext& ctx) override {
    SCANPREP_ASSIGN_OR_RETURN(const Neighbourhoods* nb, ctx.neighbourhoods());
    const RemovalStagesRun ran{.outliers = ctx.Ran(stage_names::kOutliers),
                               .correction = ctx.Ran(stage_names::kCorrection)};
    SCANPREP_ASSIGN_OR_RETURN(
        HealthReport health,
        MeasureHealth(ctx.cloud(), ctx.measures(), *nb, ctx.Settings(HealthParams()), ran,
                      ctx.out(), ctx.TakePairsBeforeRegistration()));
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

// The sensor's noise over every point it measured well: the merged-away ones included (a scan
// another sees better may lose most of its points to the merge).
absl::StatusOr<std::vector<std::optional<double>>> SensorNoise(const PointCloud& cloud,
                                                               const PointMeasures& m,
                                                               const CancelToken& cancel) {
  if (m.fit_rms.size() != cloud.size()) {
    return absl::InternalError("health: the normals stage left no fit residuals");
  }
  return MeasuredScanNoise(cloud, m, cloud.scans.size(), cancel, kRemovedOutlier);
}

}  // namespace

absl::StatusOr<std::vector<PairHealth>> MeasurePairs(const PointCloud& cloud,
                                                     const PointMeasures& m,
                                                     const Neighbourhoods& nb,
                                                     const HealthSettings& params,
                                                     const CancelToken& cancel) {
  const MisalignmentSettings settings{.min_points = params.min_overlap_points,
                                      .max_standard_error = params.max_standard_error};
  std::vector<PairHealth> out;
  if (cloud.scans.size() < 2) return out;
  SCANPREP_ASSIGN_OR_RETURN(const PairSearch search,
                            MakePairSearch(cloud, nb, params.max_pair_distance, cancel));
  // One moving scan at a time: the correspondences held at once are one scan's (up to k a point
  // where k scans overlap), not the job's.
  const std::vector<std::vector<uint32_t>> points = PointsPerScan(cloud);
  for (uint32_t moving = 1; moving < points.size(); ++moving) {
    SCANPREP_ASSIGN_OR_RETURN(auto by_fixed,
                              FindCorrespondences(cloud, m, nb, search, points[moving], cancel));
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

absl::StatusOr<HealthReport> MeasureHealth(const PointCloud& cloud, const PointMeasures& m,
                                           const Neighbourhoods& nb, const HealthSettings& settings,
                                           const RemovalStagesRun& ran, StageReporter& out,
                                           std::optional<std::vector<PairHealth>> measured_pairs) {
  SCANPREP_ASSIGN_OR_RETURN(const std::vector<std::optional<double>> noise,
                            SensorNoise(cloud, m, out.cancel()));
  HealthReport health;
  if (measured_pairs) {
    health.pairs = *std::move(measured_pairs);
  } else {
    SCANPREP_ASSIGN_OR_RETURN(health.pairs, MeasurePairs(cloud, m, nb, settings, out.cancel()));
  }
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
      .cost_weight = 0.06,
  };
}

}  // namespace scanprep
