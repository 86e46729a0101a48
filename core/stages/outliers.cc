// SPDX-License-Identifier: Apache-2.0
// The paper's global rule: a point whose nearest-neighbour distance d_1 exceeds μ + 2σ of all
// d_1 is an outlier. Statistics are taken per scan because sensors differ in density, and d_1 is
// measured to the point's own scan: in the merged cloud a point where scans overlap has a
// neighbour of another scan at a fraction of its own grid spacing, which drags μ and σ down until
// ordinary grid points of the non-overlapping parts exceed μ + 2σ (five overlapping Happy Buddha
// scans lost 3.8 % in one job against 0.35 % one by one).
//
// The rule is blind to two things, so the surface decides (core/stages/surface_spikes.h): a point
// above the threshold that lies on a plane its own scan's neighbours support is a sparse sample of
// a real surface, not an outlier (one threshold per scan otherwise removes the ordinary points of
// faces it meets obliquely: 8 % of a simulated box); and a spike a few σ off the surface has a
// nearest neighbour as close as any grid point, so only its offset from the surface gives it away.
#include "core/stages/outliers.h"

#include <algorithm>
#include <atomic>
#include <cmath>

#include "absl/strings/str_cat.h"
#include "core/base/parallel.h"
#include "core/base/status_macros.h"
#include "core/stages/neighbourhoods_stage.h"
#include "core/stages/outliers_loop.h"
#include "core/stages/scan_noise.h"
#include "core/stages/stage_context.h"
#include "core/stages/stage_names.h"
#include "core/stages/surface_spikes.h"

namespace scanprep {
namespace {

struct ScanStats {
  double sum = 0, sum_sq = 0;
  size_t count = 0;
  std::vector<float> values;  // for the median floor
};

// The paper's rule: d (d_1, or a k_o-mean) above max(μ + m·σ, floor·median) of its scan.
absl::Status FindDistanceOutliers(const PointCloud& cloud, const Neighbourhoods& nb,
                                  const OutliersSettings& rule, StageReporter& out,
                                  std::vector<uint8_t>& far) {
  const size_t n = cloud.size();

  // At most neighbourhoods.k (ValidateOverrides); only a cloud of n ≤ k points has fewer.
  const int64_t k_asked = rule.k;
  const uint32_t k_o = static_cast<uint32_t>(std::min<int64_t>(k_asked, nb.k()));
  if (k_o < k_asked) {
    out.Warn(WarningCode::kOutliersKReduced,
             absl::StrCat("outliers: outliers.k = ", k_asked, " but the cloud has ", n,
                          " points; d is averaged over ", k_o, " neighbours"));
  }

  // d_1 (or the mean over k_o neighbours, PCL-style SOR, when k_o > 1), own scan only. The
  // k-NN list holds every scan; when fewer than k_o of its points are of i's scan, the rest are
  // farther than its last entry, so that distance stands in for them: a lower bound, which can
  // only keep a point (one surrounded by another scan's denser surface).
  std::vector<float> d(n);
  std::atomic<size_t> beyond_list{0};
  SCANPREP_RETURN_IF_ERROR(ParallelFor(n, out.cancel(), [&](size_t begin, size_t end) {
    size_t beyond = 0;
    for (size_t i = begin; i < end; ++i) {
      const KnnList list = nb.knn(i);
      float sum = 0;
      uint32_t found = 0;
      for (uint32_t m = 0; m < list.size() && found < k_o; ++m) {
        if (cloud.scan[list[m]] != cloud.scan[i]) continue;
        sum += list.dist(cloud, m);
        ++found;
      }
      if (found < k_o) {
        sum += (k_o - found) * list.dist(cloud, nb.k() - 1);
        ++beyond;
      }
      d[i] = sum / static_cast<float>(k_o);
    }
    beyond_list += beyond;
  }));
  out.Record("outliers.own_scan_beyond_knn", static_cast<double>(beyond_list.load()));

  std::vector<ScanStats> stats(std::max<size_t>(cloud.scans.size(), 1));
  for (size_t i = 0; i < n; ++i) {
    // Exact duplicates (d = 0) would drag μ and σ down and flag ordinary points.
    if (cloud.removed(i) || d[i] <= 0) continue;
    ScanStats& s = stats[cloud.scan[i]];
    s.sum += d[i];
    s.sum_sq += double(d[i]) * d[i];
    ++s.count;
    s.values.push_back(d[i]);
  }
  std::vector<double> threshold(stats.size(), 0.0);
  for (size_t s = 0; s < stats.size(); ++s) {
    ScanStats& st = stats[s];
    if (st.count == 0) {
      threshold[s] = std::numeric_limits<double>::infinity();
      continue;
    }
    const double mean = st.sum / st.count;
    const double sigma = std::sqrt(std::max(0.0, st.sum_sq / st.count - mean * mean));
    auto mid = st.values.begin() + st.values.size() / 2;
    std::nth_element(st.values.begin(), mid, st.values.end());
    // A regular scan grid has σ ≈ 0; the median floor keeps its slightly wider gaps.
    threshold[s] = std::max(mean + rule.multiplier * sigma, rule.median_floor * *mid);
    out.RecordForScan("outliers.mean_d_mm", s, mean);
    out.RecordForScan("outliers.sigma_d_mm", s, sigma);
    threshold[s] = rule.threshold_mm.Or(threshold[s]);
    out.RecordForScan(rule.threshold_mm.name, s, threshold[s]);
  }

  for (size_t i = 0; i < n; ++i) {
    far[i] = !cloud.removed(i) && d[i] > threshold[cloud.scan[i]];
  }
  return absl::OkStatus();
}

// Removes the points `far` names (beyond the d threshold) unless they lie on a plane their
// neighbours support (a sparse sample of a real surface, not an
// outlier), and every point farther than
// outliers.surface_sigmas local σ off such planes. The normals are fitted first, with the far
// candidates still in: a point far off the surface lies in no other point's ball.
absl::Status RemoveFarAndOffSurface(PointCloud& cloud, const PointMeasures& m,
                                    const Neighbourhoods& nb, const OutliersSettings& settings,
                                    const std::vector<uint8_t>& far, StageReporter& out) {
  const size_t n = cloud.size();
  const double sigmas = settings.surface_sigmas;
  std::vector<uint8_t> verdict(n, kNotJudged);
  if (sigmas > 0) {
    // The plan ran "normals" before: before the outlier stage for nn (its prerequisite),
    // after LoOP's removals for loop (the surface stage's prerequisite).
    const size_t scans = std::max<size_t>(cloud.scans.size(), 1);
    SCANPREP_ASSIGN_OR_RETURN(const std::vector<std::optional<double>> noise,
                              MeasuredScanNoise(cloud, m, scans, out.cancel()));
    for (size_t s = 0; s < scans; ++s) {
      if (noise[s]) {
        out.RecordForScan("outliers.surface_noise_mm", s, *noise[s]);
      } else {
        out.Warn(WarningCode::kSurfaceSpikesSkipped,
                 absl::StrCat("outliers: scan ", s, " has fewer than ", kMinNoiseSamples,
                              " normal fits; it is not searched for surface spikes"));
      }
    }
    SurfaceSpikeCounts counts;
    SCANPREP_RETURN_IF_ERROR(
        JudgeBySurface(cloud, nb, m, noise, sigmas, out.cancel(), verdict, counts));
    out.Record("outliers.surface_not_judged", static_cast<double>(counts.not_judged));
  }
  // Without the surface test nothing is judged and the paper's threshold decides alone.
  size_t removed_far = 0, kept_on_surface = 0, spikes = 0;
  for (size_t i = 0; i < n; ++i) {
    if (cloud.removed(i)) continue;
    const bool on_a_plane = verdict[i] == kOnSurface || verdict[i] == kNearSurface;
    if (far[i] && on_a_plane) {
      ++kept_on_surface;
    } else if (far[i] || verdict[i] == kOffSurface) {
      cloud.flags[i] |= kRemovedOutlier;
      ++(far[i] ? removed_far : spikes);
    }
  }
  if (!settings.loop()) {  // LoOP recorded its own removals
    out.Record(kOutliersRemoved, static_cast<double>(removed_far + spikes));
    out.Record("outliers.far_removed", static_cast<double>(removed_far));
    out.Record("outliers.far_on_surface_kept", static_cast<double>(kept_on_surface));
  }
  out.Record("outliers.surface_spikes", static_cast<double>(spikes));
  return absl::OkStatus();
}

class OutliersStage : public Stage {
 public:
  absl::Status Run(StageContext& ctx) override {
    SCANPREP_ASSIGN_OR_RETURN(const Neighbourhoods* nb, ctx.neighbourhoods());
    return RemoveOutliers(ctx.cloud(), ctx.measures(), *nb, ctx.Settings(OutliersParams()),
                          ctx.out());
  }
};

class SurfaceSpikesStage : public Stage {
 public:
  absl::Status Run(StageContext& ctx) override {
    SCANPREP_ASSIGN_OR_RETURN(const Neighbourhoods* nb, ctx.neighbourhoods());
    // Only the parameters the surface test reads are recorded: the rest are the outlier stage's.
    return RemoveSurfaceSpikes(ctx.cloud(), ctx.measures(), *nb,
                               ctx.SettingsUsing(OutliersParams(), &OutliersSettings::method,
                                                 &OutliersSettings::surface_sigmas),
                               ctx.out());
  }
};

// Whether the outlier stage's surface test runs as a stage of its own after LoOP's removals.
bool SurfaceTestFollowsLoop(const ParamOverrides& params) {
  const OutliersSettings planned = OutliersParams().Read(params);
  return planned.surface_sigmas > 0 && planned.loop();
}

}  // namespace

absl::Status RemoveOutliers(PointCloud& cloud, const PointMeasures& m, const Neighbourhoods& nb,
                            const OutliersSettings& settings, StageReporter& out) {
  if (nb.k() == 0) return absl::OkStatus();
  std::vector<uint8_t> far(cloud.size(), 0);
  if (settings.loop()) {
    // LoOP removes its outliers itself; the surface test looks for spikes among the rest, with
    // normals fitted without them: the plan's next stages (SurfaceTestFollowsLoop).
    SCANPREP_RETURN_IF_ERROR(RemoveLoopOutliers(cloud, nb, settings, out));
    if (settings.surface_sigmas > 0) return absl::OkStatus();
  } else {
    SCANPREP_RETURN_IF_ERROR(FindDistanceOutliers(cloud, nb, settings, out, far));
  }
  return RemoveFarAndOffSurface(cloud, m, nb, settings, far, out);
}

absl::Status RemoveSurfaceSpikes(PointCloud& cloud, const PointMeasures& m,
                                 const Neighbourhoods& nb, const OutliersSettings& settings,
                                 StageReporter& out) {
  if (nb.k() == 0) return absl::OkStatus();
  // LoOP removed its own far points: only the surface decides here.
  return RemoveFarAndOffSurface(cloud, m, nb, settings, std::vector<uint8_t>(cloud.size(), 0), out);
}

const ParamTable<OutliersSettings>& OutliersParams() {
  using S = OutliersSettings;
  const auto nn = [](const S& s) { return !s.loop(); };
  const auto loop = [](const S& s) { return s.loop(); };
  // Neither neighbour count may exceed the shared graph's.
  const std::string& graph_k = NeighbourhoodsParams().Name(&NeighbourhoodsSettings::k);
  static const ParamTable<S> table = {
      param::Choice(&S::method, "outliers.method", {"nn", "loop"},
                    "nn: the paper's global d_1 rule; loop: Local Outlier Probabilities for "
                    "strongly varying density"),
      param::Integer(&S::k, "outliers.k", 1, Closed(1, 64),
                     "neighbours averaged into d (1 = the paper's d_1)")
          .AtMost(graph_k)
          .When(nn),
      param::Real(&S::multiplier, "outliers.multiplier", 2, Closed(0, 100),
                  "σ multiplier of the threshold μ + m·σ")
          .When(nn),
      param::Real(&S::surface_sigmas, "outliers.surface_sigmas", 4, Closed(0, 1000),
                  "a point farther than this many local σ from every plane its scan's neighbours "
                  "support is a spike (0 = no surface test)"),
      param::Real(&S::median_floor, "outliers.median_floor", 1.5, Closed(0, 100),
                  "the threshold is at least this times median(d)")
          .When(nn),
      param::DerivedReal(&S::threshold_mm, "outliers.threshold_mm",
                         "max(μ + m·σ, floor·median) per scan", LeftOpen(0, 1e4),
                         "distance above which a point is an outlier"),
      param::DerivedInteger(&S::loop_k, "outliers.loop_k", graph_k, Closed(1, 64),
                            "LoOP neighbourhood size")
          .AtMost(graph_k),
      param::Real(&S::loop_lambda, "outliers.loop_lambda", 3, LeftOpen(0, 100),
                  "LoOP λ (standard deviations of the probabilistic distance)")
          .When(loop),
      param::Real(&S::loop_threshold, "outliers.loop_threshold", 0.8, Closed(0, 1),
                  "LoOP probability above which a point is an outlier")
          .When(loop),
  };
  return table;
}

StageInfo OutliersStageInfo() {
  return {
      .name = std::string(stage_names::kOutliers),
      .summary =
          "statistical outlier removal: d_1 > max(μ + 2σ, 1.5·median) per scan unless "
          "the point lies on a plane its neighbours support; and points more than 4σ off "
          "every such plane",
      .params = OutliersParams().Specs(),
      .make = [] { return std::make_unique<OutliersStage>(); },
      .prerequisites =
          [](const ParamOverrides& params) {
            // The surface test needs the normals, fitted before anything is removed; LoOP removes
            // its outliers first, so its surface test is a stage of its own after the normals.
            std::vector<std::string> need = stage_names::List({stage_names::kNeighbourhoods});
            const OutliersSettings planned = OutliersParams().Read(params);
            if (planned.surface_sigmas > 0 && !planned.loop())
              need.emplace_back(stage_names::kNormals);
            return need;
          },
      .followers =
          [](const ParamOverrides& params) {
            return SurfaceTestFollowsLoop(params) ? stage_names::List({stage_names::kSurfaceSpikes})
                                                  : std::vector<std::string>{};
          },
      .work_per_point = 2,
      .cost_weight = 2.71,
  };
}

StageInfo SurfaceSpikesStageInfo() {
  return {
      .name = std::string(stage_names::kSurfaceSpikes),
      .summary =
          "the outlier stage's surface test after LoOP's removals, on normals fitted "
          "without them",
      .make = [] { return std::make_unique<SurfaceSpikesStage>(); },
      .prerequisites =
          [](const ParamOverrides&) {
            return stage_names::List({stage_names::kOutliers, stage_names::kNormals});
          },
      // One metered pass (JudgeBySurface). Not in the default plan, where the weights were
      // measured: weighted as the lightest stage.
      .work_per_point = 1,
      .cost_weight = 1,
  };
}

}  // namespace scanprep
