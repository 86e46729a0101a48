// SPDX-License-Identifier: Apache-2.0
// Edge-preserving smoothing (paper §3.1, Eqs. 6-10; docs/algorithms.md §11; docs/algorithms.md for
// the deviation). Every point's weights combine viewing quality and flatness (Eq. 6) with a
// distance fall-off (Eq. 9). By default each point is projected onto the plane of its own side of
// the surface, fitted to the neighbours within a few noise σ of it, and σ is measured from the data
// (the normals' fit residuals), not taken from the scanner's stated u: with an honest u the paper's
// rule δ = u rejects most noise-sized moves, and with an inflated one it lets edges round off.
// The paper's weighted mean with δ = u (Eqs. 8, 10) is `smoothing.method = mean`.
#include "core/stages/smoothing.h"

#include <algorithm>
#include <cmath>
#include <optional>

#include "absl/strings/str_cat.h"
#include "core/base/free_memory.h"
#include "core/base/parallel.h"
#include "core/base/quality_order.h"
#include "core/base/status_macros.h"
#include "core/stages/scan_noise.h"
#include "core/stages/smoothing_kernels.h"
#include "core/stages/stage_context.h"
#include "core/stages/stage_names.h"

namespace scanprep {
namespace {

// Progress: parallel-loop items per point that one iteration meters (its pass, and the
// neighbourhoods rebuilt for the points it moved), measured on the simulated scans.
constexpr double kLoopItemsPerIteration = 4;

// σ̂ and δ per scan (SmoothingSettings::noise, tolerance), recorded with their warnings.
absl::Status DeriveTolerances(const PointCloud& cloud, const PointMeasures& m, SmoothingSettings& s,
                              StageReporter& out) {
  const size_t scans = std::max<size_t>(cloud.scans.size(), 1);
  const std::optional<double> forced = s.tolerance_mm.forced;
  const std::optional<double> forced_noise = s.noise_mm.forced;
  s.fixed_tolerance = forced.has_value() || !s.own_side();
  SCANPREP_ASSIGN_OR_RETURN(const std::vector<std::optional<double>> measured,
                            MeasuredScanNoise(cloud, m, scans, out.cancel()));
  size_t tolerance_from_default = 0;
  for (size_t scan = 0; scan < scans; ++scan) {
    const double u = scan < cloud.scans.size() ? cloud.scans[scan].uncertainty : 0.1;
    double noise = forced_noise.value_or(measured[scan].value_or(u));
    if (s.own_side() && !forced_noise && !measured[scan]) {
      out.Warn(WarningCode::kNoiseUnmeasured,
               absl::StrCat("smoothing: scan ", scan,
                            " has too few normal fits to measure its "
                            "noise; its stated uncertainty u = ",
                            u, " mm stands in"));
    }
    if (s.own_side() && !forced_noise && measured[scan] && noise > 3 * u) {
      out.Warn(WarningCode::kNoiseAboveUncertainty,
               absl::StrCat("smoothing: scan ", scan, " is noisier (σ̂ = ", noise,
                            " mm) than three times its stated uncertainty u = ", u,
                            " mm: is the unit or u right?"),
               {{"scan", absl::StrCat(scan)},
                {"noise_mm", absl::StrCat(noise)},
                {"uncertainty_mm", absl::StrCat(u)}});
    }
    s.noise.push_back(static_cast<float>(noise));
    // δ = u (the paper), or kMoveSigmas·σ̂ at the scan's typical noise (own side).
    s.tolerance.push_back(
        static_cast<float>(forced.value_or(s.own_side() ? kMoveSigmas * noise : u)));
    if (s.own_side()) out.RecordForScan(s.noise_mm.name, scan, noise);
    const bool default_u = scan < cloud.scans.size() && !cloud.scans[scan].uncertainty_stated;
    if (!forced && s.fixed_tolerance && default_u) {
      ++tolerance_from_default;
      out.Warn(WarningCode::kToleranceFromDefaultUncertainty,
               absl::StrCat("smoothing: scan ", scan,
                            " states no uncertainty; δ is the default "
                            "u = ",
                            u, " mm (smoothing.method = own_side measures the noise)"));
    }
    out.RecordForScan(s.tolerance_mm.name, scan, s.tolerance.back());
  }
  out.Record("smoothing.tolerance_from_default_u", static_cast<double>(tolerance_from_default));
  return absl::OkStatus();
}

class SmoothingStage : public Stage {
 public:
  absl::Status Run(StageContext& ctx) override {
    SCANPREP_ASSIGN_OR_RETURN(Neighbourhoods * nb, ctx.neighbourhoods());
    return Smooth(ctx.cloud(), ctx.measures(), *nb, ctx.Settings(SmoothingParams()), ctx.out());
  }
};

}  // namespace

absl::Status Smooth(PointCloud& cloud, const PointMeasures& m, Neighbourhoods& nb,
                    SmoothingSettings settings, StageReporter& out) {
  const size_t n = cloud.size();
  if (m.quality.size() != n || m.curvature.size() != n || m.fit_rms.size() != n) {
    return absl::InternalError("smoothing: the measures stage left no quality/curvature/fit");
  }
  SCANPREP_RETURN_IF_ERROR(DeriveTolerances(cloud, m, settings, out));
  // Without poses every q̂ is the same and Eq. (6) weighs by flatness alone.
  const bool uniform = UniformQuality(cloud, m.quality);
  out.Record("smoothing.without_quality", uniform ? 1 : 0);
  if (uniform && settings.lambda > 0) {
    out.Warn(WarningCode::kSmoothingWithoutQuality,
             "smoothing: every point has the same viewing quality (no sensor poses), so the "
             "weights of Eq. (6) tell points apart by flatness alone");
  }
  const int iterations = settings.iterations;
  out.ExpectWork(kLoopItemsPerIteration * iterations * double(n));

  std::vector<uint8_t> outcome(n);
  std::vector<uint8_t> moved_ever(n, 0);
  size_t counts[5] = {};
  double shift_sum = 0;
  for (int it = 0; it < iterations; ++it) {
    const SmoothingInputs in{cloud, nb, m, settings};
    const std::span<const uint32_t> order = nb.order();
    std::vector<Eigen::Vector3f> next(n);
    SCANPREP_RETURN_IF_ERROR(ParallelFor(n, out.cancel(), [&](size_t begin, size_t end) {
      SmoothingScratch scratch;
      for (size_t v = begin; v < end; ++v) {
        const size_t i = order[v];
        outcome[i] = SmoothPoint(in, i, scratch, next[i]);
      }
    }));
    float max_shift = 0;
    for (size_t i = 0; i < n; ++i) {
      ++counts[outcome[i]];
      if (outcome[i] != kMoved && outcome[i] != kClamped) continue;
      moved_ever[i] = 1;
      const float shift = (cloud.point(i) - next[i]).norm();
      shift_sum += shift;
      max_shift = std::max(max_shift, shift);
    }
    // Jacobi update: every new position came from the pre-pass positions.
    for (size_t i = 0; i < n; ++i) {
      cloud.x[i] = next[i].x(), cloud.y[i] = next[i].y(), cloud.z[i] = next[i].z();
    }
    FreeMemory(next);  // before the grid is rebuilt on the new positions
    SCANPREP_RETURN_IF_ERROR(nb.PointsMoved(cloud, max_shift, out.cancel()));
    out.Progress((it + 1.0) / iterations);
  }
  for (size_t i = 0; i < n; ++i) {
    if (moved_ever[i]) cloud.flags[i] |= kSmoothed;
  }
  const size_t shifted = counts[kMoved] + counts[kClamped];
  out.Record("smoothing.moved", static_cast<double>(counts[kMoved]));
  out.Record("smoothing.clamped", static_cast<double>(counts[kClamped]));
  out.Record("smoothing.rejected", static_cast<double>(counts[kRejected]));
  out.Record("smoothing.unfitted", static_cast<double>(counts[kUnfitted]));
  out.Record("smoothing.mean_shift_mm", shifted > 0 ? shift_sum / double(shifted) : 0.0);
  return absl::OkStatus();
}

const ParamTable<SmoothingSettings>& SmoothingParams() {
  using S = SmoothingSettings;
  static const ParamTable<S> table = {
      param::Choice(&S::method, "smoothing.method", {"own_side", "mean"},
                    "own_side: projection onto the plane of the point's own side, δ = 3σ from the "
                    "data; mean: the paper's Eq. (8) with δ = u"),
      param::Choice(&S::neighbourhood, "smoothing.neighbourhood", {"ball", "knn"},
                    "ball: r_p = max(r_min, d_k), the paper's; knn: the k-NN list alone (cheaper)"),
      param::Real(&S::lambda, "smoothing.lambda", 0.5, Closed(0, 1),
                  "λ of Eq. (6): share of viewing quality vs. flatness in w_j"),
      param::Choice(&S::influence, "smoothing.influence", {"cubic", "gauss", "average"},
                    "distance fall-off Φ: 1-0.8x³, e^{-2x²} or none"),
      param::Choice(&S::mode, "smoothing.mode", {"mean", "blend"},
                    "mean method: p' of Eq. (8), or blend: p + w_p·(p' - p), each point's move "
                    "scaled by its own weight"),
      param::Choice(&S::tolerance_rule, "smoothing.tolerance", {"reject", "clamp"},
                    "a move longer than δ is rejected (Eq. 10) or clamped to δ"),
      param::DerivedReal(&S::noise_mm, "smoothing.noise_mm",
                         "per scan, the median RMS residual of its normal fits (u when fewer than "
                         "32 fits)",
                         LeftOpen(0, 1e4), "own_side: the noise σ the gates and δ are set in"),
      param::DerivedReal(&S::tolerance_mm, "smoothing.tolerance_mm",
                         "own_side: 3σ per point, σ its fit residual within [σ̂, 2σ̂] of its scan; "
                         "mean: the scan's uncertainty u",
                         Closed(0, 1e4), "δ of Eq. (10)"),
      // Each pass costs the first one's time again, 29 % of a default job (the cost weights
      // below, measured at 1 M points): 7 passes keep the job within 3× its default's time
      // (100 k points through the service: 100 passes were 20×).
      param::Integer(&S::iterations, "smoothing.iterations", 1, Closed(0, 7),
                     "Jacobi passes, each from the previous pass's positions"),
  };
  return table;
}

StageInfo SmoothingStageInfo() {
  return {
      .name = std::string(stage_names::kSmoothing),
      .summary =
          "edge-sharpening smoothing: each point projected onto its own side's plane, "
          "fitted with the weights of Eqs. 6 and 9 within 3 measured σ; or the paper's "
          "weighted mean with moves longer than u rejected (Eqs. 6-10)",
      .params = SmoothingParams().Specs(),
      .make = [] { return std::make_unique<SmoothingStage>(); },
      .prerequisites =
          [](const ParamOverrides&) { return stage_names::List({stage_names::kMeasures}); },
      .work_per_point = kLoopItemsPerIteration,  // one iteration, the default
      .cost_weight = 3.17,
  };
}

}  // namespace scanprep
