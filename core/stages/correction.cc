// SPDX-License-Identifier: Apache-2.0
// Where scans overlap, the worse-viewed layer goes: inside N_{r_c}(p) every point whose viewing
// quality q̂ lies below the neighbourhood mean q̄ is removed. r_c = ‖(Δs, u, Δp)‖ (Eq. 11) is the
// smallest ball that reliably reaches the other layer: Δs alone is too large, u alone too small.
//
// Gather form (default): each point decides from its own neighbourhood and the labels of the
// previous round, so the result is parallel and independent of visiting order; rounds repeat
// until nothing changes. Guard: only where N holds points of ≥ 2 scans, and never a point of the
// scan that owns the best point of N, so regions seen by one scan are not thinned. Scatter form
// (the paper's literal reading): centres in descending q̂ remove their below-mean neighbours
// immediately.
#include "core/stages/correction.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <span>

#include "absl/strings/str_cat.h"
#include "core/base/parallel.h"
#include "core/base/quality_order.h"
#include "core/base/status_macros.h"
#include "core/stages/scan_spacing.h"
#include "core/stages/stage_context.h"
#include "core/stages/stage_names.h"

namespace scanprep {
namespace {

// r_c is held to this multiple of r_g. Each term of Eq. (11) is about one sampling step, and r_g
// (d_k at k = 20) about 2.5 steps on a surface, so an honest r_c stays near r_g; one of 2·r_g
// already reaches ~5 steps, and a larger one comes from a unit slip or an override.
constexpr double kMaxMergeRadiusPerGlobalRadius = 2.0;

// What N_{r_c}(p) says: its mean quality, the scan of its best point, whether it spans scans.
struct Verdict {
  float mean_quality = 0;
  uint32_t best_scan = 0;
  bool overlap = false;
};

bool SpansScans(const PointCloud& cloud, const RadiusMatches& matches) {
  return std::any_of(matches.begin(), matches.end(), [&](const auto& m) {
    return cloud.scan[m.first] != cloud.scan[matches.front().first];
  });
}

Verdict Judge(const PointCloud& cloud, const std::vector<float>& quality,
              const RadiusMatches& matches) {
  Verdict v;
  double sum = 0;
  uint32_t best = matches.front().first;
  for (const auto& [j, d2] : matches) {
    sum += quality[j];
    if (quality[j] > quality[best] || (quality[j] == quality[best] && j < best)) best = j;
  }
  v.mean_quality = static_cast<float>(sum / static_cast<double>(matches.size()));
  v.overlap = SpansScans(cloud, matches);
  v.best_scan = cloud.scan[best];
  return v;
}

bool ShouldGo(const PointCloud& cloud, const std::vector<float>& quality, const Verdict& v,
              uint32_t j) {
  return v.overlap && cloud.scan[j] != v.best_scan && quality[j] < v.mean_quality;
}

// The report's count of the points the merge removed, whichever way the stage ends.
constexpr std::string_view kRemoved = "correction.removed";

// r_c per scan, scaled; recorded per scan when there are several.
absl::StatusOr<std::vector<float>> Radii(const PointCloud& cloud,
                                         const CorrectionSettings& settings,
                                         const Neighbourhoods& nb, StageReporter& out) {
  const double scale = settings.radius_scale;
  SCANPREP_ASSIGN_OR_RETURN(const std::vector<double> spacing,
                            ScanPointSpacing(cloud, &nb, out.cancel()));
  std::vector<float> radius;
  for (size_t s = 0; s < cloud.scans.size(); ++s) {
    const ScanMeta& scan = cloud.scans[s];
    const double ds = cloud.kind == ScannerKind::kLine ? scan.scanline_spacing : 0.0;
    const double r_c = std::sqrt(ds * ds + scan.uncertainty * scan.uncertainty +
                                 spacing[s] * spacing[s]);  // Eq. (11)
    radius.push_back(static_cast<float>(out.CapRadius(
        absl::StrCat("the merge radius r_c (Eq. 11) of scan '", scan.id, "'"),
        settings.radius.Or(scale * r_c), kMaxMergeRadiusPerGlobalRadius * nb.global_radius())));
    out.RecordForScan(settings.radius.name, s, radius.back());
  }
  return radius;
}

// touched[i] = 1 for every centre i whose ball N_{r_c}(i) held a point that `gone` marks: the
// balls of radius max r_c around the gone points hold every such centre. When one of those
// balls is capped it may miss some, and every centre is judged again.
absl::Status TouchBallsThatLost(const PointCloud& cloud, const Neighbourhoods& nb,
                                const std::vector<float>& radius, const std::vector<uint8_t>& gone,
                                std::vector<uint8_t>& touched, const CancelToken& cancel) {
  const float reach = *std::max_element(radius.begin(), radius.end());
  const std::span<const uint32_t> order = nb.order();
  std::fill(touched.begin(), touched.end(), 0);
  std::atomic<bool> capped{false};
  SCANPREP_RETURN_IF_ERROR(ParallelFor(order.size(), cancel, [&](size_t begin, size_t end) {
    RadiusMatches matches;
    for (size_t at = begin; at < end; ++at) {
      const uint32_t j = order[at];
      if (!gone[j]) continue;
      if (!nb.Within(cloud, j, reach, matches)) capped.store(true, std::memory_order_relaxed);
      for (const auto& [i, d2] : matches) {
        const float r = radius[cloud.scan[i]];
        if (d2 < r * r) std::atomic_ref<uint8_t>(touched[i]).store(1, std::memory_order_relaxed);
      }
    }
  }));
  if (capped.load()) std::fill(touched.begin(), touched.end(), 1);
  return absl::OkStatus();
}

// Rounds of the gather rule, each from the previous round's labels, until nothing changes.
// One round thins every layer of a multi-scan overlap by about half; later rounds see the
// raised mean of what is left and strip the worse layers completely, as the scatter form does.
absl::StatusOr<size_t> Gather(PointCloud& cloud, const Neighbourhoods& nb,
                              const std::vector<float>& quality, const std::vector<float>& radius,
                              int max_rounds, StageReporter& out) {
  const size_t n = cloud.size();
  std::vector<uint8_t> go(n, 0);
  // Balls only lose points from round to round, so a ball that holds one scan never spans two
  // again: its centre is settled for good.
  std::vector<uint8_t> settled(n, 0);
  // A verdict changes only when its ball lost a point: after the first round only the
  // centres within r_c of a point the last round removed are judged again.
  std::vector<uint8_t> touched(n, 1);
  // Grid order: consecutive balls read the same cells.
  const std::span<const uint32_t> order = nb.order();
  size_t removed = 0;
  int round = 0;
  // At most: a round that removes nothing ends it. Each round passes over the points twice
  // (judging, then finding the centres near its removals).
  out.ExpectWork(2.0 * max_rounds * double(n));
  while (round < max_rounds) {
    SCANPREP_RETURN_IF_ERROR(ParallelFor(n, out.cancel(), [&](size_t begin, size_t end) {
      RadiusMatches matches;
      for (size_t at = begin; at < end; ++at) {
        const uint32_t i = order[at];
        go[i] = 0;
        if (cloud.removed(i) || settled[i] || !touched[i]) continue;
        nb.Sample(cloud, i, radius[cloud.scan[i]], matches);
        const Verdict v = Judge(cloud, quality, matches);
        settled[i] = !v.overlap;
        go[i] = ShouldGo(cloud, quality, v, i);
      }
    }));
    ++round;
    size_t now = 0;
    for (size_t i = 0; i < n; ++i) {
      if (!go[i]) continue;
      cloud.flags[i] |= kRemovedMerge;
      ++now;
    }
    removed += now;
    out.Progress(double(round) / max_rounds);
    if (now == 0 || round == max_rounds) break;
    SCANPREP_RETURN_IF_ERROR(TouchBallsThatLost(cloud, nb, radius, go, touched, out.cancel()));
  }
  out.Record("correction.rounds_run", round);
  return removed;
}

absl::StatusOr<size_t> Scatter(PointCloud& cloud, const Neighbourhoods& nb,
                               const std::vector<float>& quality, const std::vector<float>& radius,
                               StageReporter& out) {
  std::vector<uint64_t> keys(cloud.size());
  for (uint32_t i = 0; i < cloud.size(); ++i) keys[i] = DescendingQualityKey(quality[i], i);
  SCANPREP_RETURN_IF_ERROR(CancellableSort(keys, out.cancel()));
  std::vector<uint32_t> order(keys.size());
  for (size_t v = 0; v < keys.size(); ++v) order[v] = static_cast<uint32_t>(keys[v]);
  RadiusMatches matches;
  size_t removed = 0;
  for (size_t visited = 0; visited < order.size(); ++visited) {
    // Before the skip of removed centres: a run of them must not skip the check too.
    if (out.cancel().CancelledAt(visited)) return out.cancel().Check();
    if ((visited & 0xffff) == 0) out.Progress(double(visited) / order.size());
    const uint32_t i = order[visited];
    if (cloud.removed(i)) continue;
    nb.Within(cloud, i, radius[cloud.scan[i]], matches);
    if (matches.size() < 2) continue;
    const Verdict v = Judge(cloud, quality, matches);
    for (const auto& [j, d2] : matches) {
      if (!ShouldGo(cloud, quality, v, j)) continue;
      cloud.flags[j] |= kRemovedMerge;
      ++removed;
    }
  }
  return removed;
}

class CorrectionStage : public Stage {
 public:
  absl::Status Run(StageContext& ctx) override {
    SCANPREP_ASSIGN_OR_RETURN(const Neighbourhoods* nb, ctx.neighbourhoods());
    // Read here, recorded only when there was an overlap to merge (the parameters were used).
    const CorrectionSettings settings = CorrectionParams().Read(ctx.overrides());
    SCANPREP_ASSIGN_OR_RETURN(
        const bool merged, CorrectOverlaps(ctx.cloud(), ctx.measures(), *nb, settings, ctx.out()));
    if (merged) ctx.RecordSettings(CorrectionParams(), settings);
    return absl::OkStatus();
  }
};

}  // namespace

absl::StatusOr<bool> CorrectOverlaps(PointCloud& cloud, const PointMeasures& m,
                                     const Neighbourhoods& nb, const CorrectionSettings& settings,
                                     StageReporter& out) {
  out.Record("correction.single_scan", cloud.scans.size() < 2 ? 1 : 0);
  if (cloud.scans.size() < 2) {  // nothing can overlap
    out.Record(kRemoved, 0);
    out.Warn(WarningCode::kSingleScanNoMerge,
             "correction: the job has one scan, so there is no overlap to merge and nothing "
             "was changed; send each scan as its own scan (one file per scan, or a per-point "
             "scan column)");
    return false;
  }
  const std::vector<float>& quality = m.quality;
  if (quality.size() != cloud.size()) {
    return absl::InternalError("correction: the measures stage left no viewing quality");
  }
  // Without sensor poses or a scanner quality every q̂ is the same, no point is below its
  // neighbourhood's mean, and the merge would run to no effect: say so instead.
  const bool uniform = UniformQuality(cloud, quality);
  out.Record("correction.without_quality", uniform ? 1 : 0);
  if (uniform) {
    out.Record(kRemoved, 0);
    out.Warn(WarningCode::kUniformQualityNoMerge,
             "correction: every point has the same viewing quality (no scan has sensor poses "
             "or a per-point quality), so overlapping scans cannot be told apart and were not "
             "merged; give view or camera/projector directions, or quality per point");
    return false;
  }
  SCANPREP_ASSIGN_OR_RETURN(const std::vector<float> radius, Radii(cloud, settings, nb, out));
  SCANPREP_ASSIGN_OR_RETURN(const size_t removed,
                            settings.mode == CorrectionMode::kScatter
                                ? Scatter(cloud, nb, quality, radius, out)
                                : Gather(cloud, nb, quality, radius, settings.rounds, out));
  out.Record(kRemoved, static_cast<double>(removed));
  return true;
}

const ParamTable<CorrectionSettings>& CorrectionParams() {
  using S = CorrectionSettings;
  static const ParamTable<S> table = {
      param::Choice(&S::mode, "correction.mode", {"gather", "scatter"},
                    "gather: each point decides from its own neighbourhood (parallel, "
                    "order-free); scatter: centres in descending quality remove neighbours at "
                    "once (paper)"),
      param::Integer(&S::rounds, "correction.rounds", 10, Closed(1, 1000),
                     "most gather rounds, each from the previous round's labels (1 = a single "
                     "pass); stops early when a round removes nothing")
          .When([](const S& s) { return s.mode == CorrectionMode::kGather; }),
      param::Real(&S::radius_scale, "correction.radius_scale", 1, LeftOpen(0, 100),
                  "factor on r_c, for registration residuals larger than r_c"),
      param::DerivedReal(&S::radius, "correction.radius_mm",
                         "radius_scale·√(Δs² + u² + Δp²) per scan", LeftOpen(0, 1e4),
                         "r_c of Eq. (11) for every scan"),
  };
  return table;
}

StageInfo CorrectionStageInfo() {
  return {
      .name = std::string(stage_names::kCorrection),
      .summary =
          "merge overlapping scans: in N_{r_c}(p) spanning ≥ 2 scans, remove points of "
          "other scans than the best point's whose quality is below the mean (Eq. 11)",
      .params = CorrectionParams().Specs(),
      .make = [] { return std::make_unique<CorrectionStage>(); },
      .prerequisites =
          [](const ParamOverrides&) { return stage_names::List({stage_names::kMeasures}); },
      .work_per_point = 1,
      .cost_weight = 0.72,
  };
}

}  // namespace scanprep
