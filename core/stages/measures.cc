// SPDX-License-Identifier: Apache-2.0
// q̂ = 1 − max(α, β)/(π/2) from the normals and the sensor geometry (or the scanner's own
// quality), κ̂ = min(κ/s, 1) from the scanline curvature, with surface variation as the fallback
// where a scanline window does not exist (no scanlines, segment ends, short lines).
#include "core/stages/measures.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <numbers>
#include <optional>

#include "absl/strings/str_cat.h"
#include "core/base/parallel.h"
#include "core/base/status_macros.h"
#include "core/spatial/view_geometry.h"
#include "core/stages/noise_bounds.h"
#include "core/stages/scan_noise.h"
#include "core/stages/scan_spacing.h"
#include "core/stages/scanline_curvature.h"
#include "core/stages/stage_context.h"
#include "core/stages/stage_names.h"

namespace scanprep {

namespace {

// The smallest window that keeps flat-surface noise below half the edge scale at 99 %: the
// least-squares x² coefficient over a window of half-width h, with points Δp apart and noise σ,
// has variance 45·σ²·Δp/(8h⁵); asking 2·2.6·std(a2) <= s/(2·√2) (√2 for the Gaussian weights)
// gives h⁵ >= 1215·σ²·Δp/s².
double NoiseWindow(double sigma, double spacing, double scale) {
  return std::pow(1215.0 * sigma * sigma * spacing / (scale * scale), 0.2);
}

bool HasNormal(const PointCloud& cloud, size_t i) {
  return !cloud.removed(i) && !(cloud.flags[i] & kNormalInvalid);
}

// Points the stage could not measure (`unknown`) take the median of the measured points of their
// scan: a neutral value, neither the best weight (q̂ = 1, κ̂ = 0 would let a point without a normal
// win every merge and pull every smoothing) nor the worst. 0.5 when the scan has no measured point.
template <typename Unknown>
void AssignScanMedians(const PointCloud& cloud, Unknown unknown, std::vector<float>& values) {
  std::vector<std::vector<float>> measured(cloud.scans.size());
  for (size_t i = 0; i < cloud.size(); ++i) {
    if (!cloud.removed(i) && !unknown(i)) measured[cloud.scan[i]].push_back(values[i]);
  }
  std::vector<float> median(cloud.scans.size(), 0.5f);
  for (size_t s = 0; s < median.size(); ++s) {
    std::vector<float>& v = measured[s];
    if (v.empty()) continue;
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    median[s] = v[v.size() / 2];
  }
  for (size_t i = 0; i < cloud.size(); ++i) {
    if (!cloud.removed(i) && unknown(i)) values[i] = median[cloud.scan[i]];
  }
}

absl::Status Quality(const PointCloud& cloud, PointMeasures& m, StageReporter& out) {
  const size_t n = cloud.size();
  std::vector<float>& quality = m.quality;
  quality.assign(n, 1.f);
  if (cloud.quality.size() == n) {
    out.Record("measures.quality_from_scanner", 1);
    return ParallelFor(n, out.cancel(), [&](size_t begin, size_t end) {
      for (size_t i = begin; i < end; ++i) {
        quality[i] = std::isfinite(cloud.quality[i]) ? std::clamp(cloud.quality[i], 0.f, 1.f) : 0.f;
      }
    });
  }
  out.Record("measures.quality_from_scanner", 0);
  size_t without_pose = 0;
  for (size_t s = 0; s < cloud.scans.size(); ++s) {
    const ScanMeta& scan = cloud.scans[s];
    if (!TowardCamera(scan, Eigen::Vector3d::Zero()) &&
        !TowardProjector(scan, Eigen::Vector3d::Zero())) {
      ++without_pose;
      out.Warn(WarningCode::kNoPose,
               absl::StrCat("measures: scan '", scan.id,
                            "' has neither sensor poses nor a "
                            "per-point quality; its viewing quality is set to 1"));
    }
  }
  out.Record("measures.scans_without_pose", static_cast<double>(without_pose));
  SCANPREP_RETURN_IF_ERROR(ParallelFor(n, out.cancel(), [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      if (!HasNormal(cloud, i)) continue;
      const ScanMeta& scan = cloud.scans[cloud.scan[i]];
      const Eigen::Vector3d p = cloud.point(i).cast<double>();
      const Eigen::Vector3d normal = cloud.normal(i).cast<double>();
      const auto camera = TowardCamera(scan, p);
      const auto projector = TowardProjector(scan, p);
      if (!camera && !projector) continue;
      const double alpha = camera ? ViewAngle(normal, *camera) : 0.0;
      const double beta = projector ? ViewAngle(normal, *projector) : alpha;
      const double q = std::max(alpha, beta);
      quality[i] = static_cast<float>(1.0 - q / (std::numbers::pi / 2));  // Eq. (7)
    }
  }));
  // Points without a valid normal have no viewing angle.
  const auto no_normal = [&](size_t i) { return !HasNormal(cloud, i); };
  AssignScanMedians(cloud, no_normal, quality);
  return absl::OkStatus();
}

// The scanline curvature window h per scan (recorded with the spacing it comes from).
absl::StatusOr<std::vector<double>> Windows(const PointCloud& cloud, const Neighbourhoods* nb,
                                            const MeasuresSettings& settings, StageReporter& out) {
  SCANPREP_ASSIGN_OR_RETURN(const std::vector<double> spacing,
                            ScanPointSpacing(cloud, nb, out.cancel()));
  std::vector<double> window(cloud.scans.size(), 0.0);
  for (size_t s = 0; s < cloud.scans.size(); ++s) {
    const double u = cloud.scans[s].uncertainty;
    window[s] = settings.window.Or(
        std::max({3 * spacing[s], 2 * u, NoiseWindow(u, spacing[s], settings.scale)}));
    out.RecordForScan("measures.point_spacing_mm", s, spacing[s]);
    out.RecordForScan(settings.window.name, s, window[s]);
  }
  return window;
}

// κ of every scanline window (`curvatures`), when the cloud is a line scan with scanlines (the
// return value); the warnings for a line scan without them and for capped windows.
absl::StatusOr<bool> ScanlineStep(const PointCloud& cloud, const std::vector<double>& window,
                                  StageReporter& out, ScanlineCurvatures& curvatures) {
  const bool lines = cloud.kind == ScannerKind::kLine && cloud.has_scanlines();
  // A line scanner's κ̂ comes from its scanlines (Eq. 11); without them every point falls back
  // to surface variation (Eq. 12), which blurs edges over the whole ball. Flexible scanners
  // have no scanlines by design, so only a line scan that lost them is warned about.
  const bool line_scan_without_scanlines = cloud.kind == ScannerKind::kLine && !lines;
  out.Record("measures.line_scan_without_scanlines", line_scan_without_scanlines ? 1 : 0);
  if (line_scan_without_scanlines) {
    out.Warn(WarningCode::kNoScanlines,
             "measures: the line scans came without scanline indices, so curvature κ̂ is "
             "surface variation (Eq. 12) everywhere instead of scanline curvature (Eq. 11); "
             "send the scanline of every point");
  }
  if (!lines) return false;
  ScanlineCurvatureCounts counts;
  SCANPREP_RETURN_IF_ERROR(ScanlineCurvature(cloud, window, out.cancel(), curvatures, counts));
  out.Record("measures.windows_capped", static_cast<double>(counts.windows_capped));
  if (counts.windows_capped > 0) {
    out.Warn(WarningCode::kWindowsCapped,
             absl::StrCat("measures: ", counts.windows_capped, " scanline windows held more than ",
                          kMaxWindowSide,
                          " points on a side and were cut to that; measures.window_mm may be far "
                          "too large for the point spacing (or given in the wrong unit)"));
  }
  return true;
}

// The median fit residual ρ̂ noise gives a plane, per scan (MeasuredScanNoise); from the stated u
// where none was measured.
absl::StatusOr<std::vector<float>> MedianFitPerScan(const PointCloud& cloud, const PointMeasures& m,
                                                    const NoiseBounds& bounds,
                                                    const CancelToken& cancel) {
  SCANPREP_ASSIGN_OR_RETURN(const std::vector<std::optional<double>> measured,
                            MeasuredScanNoise(cloud, m, cloud.scans.size(), cancel));
  std::vector<float> median(cloud.scans.size());
  for (size_t s = 0; s < median.size(); ++s) {
    median[s] = static_cast<float>(
        measured[s].value_or(cloud.scans[s].uncertainty / bounds.sigma_per_median));
  }
  return median;
}

// A point's κ̂ (Eq. 7) and κ̂ less what noise alone makes of a plane there (the edge decision),
// from its scanline window or else its surface variation.
struct Judged {
  double curvature, beyond_noise;
};

Judged FromScanline(const ScanlineCurvatures& c, size_t i, double sigma,
                    const MeasuresSettings& settings) {
  // Less what noise σ makes of a straight line in this window, at 99.9 %; and only where a
  // smooth curve plus noise does not explain the window: a bore or a fillet is curvature, not
  // an edge.
  const double noise_kappa = NoiseBounds::kZ * sigma * c.noise_per_sigma[i];
  const bool kink = c.misfit[i] > sigma * sigma;
  return {c.kappa[i] / settings.scale,
          kink ? std::max(0.0, c.kappa[i] - noise_kappa) / settings.scale : 0.0};
}

Judged FromVariation(const PointMeasures& m, size_t i, double median_fit, double fit_ms_bound,
                     const MeasuresSettings& settings) {
  const double value = m.surface_variation[i] / settings.variation_scale;  // Eq. (12) fallback
  // Less the share of the fit's spread that a plane's noise accounts for at 99.9 %.
  const double fit = m.fit_rms[i];
  const double noise_ms = fit_ms_bound * median_fit * median_fit;
  return {value, fit > 0 ? value * std::max(0.0, 1 - noise_ms / (fit * fit)) : 0.0};
}

struct EdgeCounts {
  size_t flagged = 0;       // EDGE: κ̂ less noise at the threshold
  size_t at_threshold = 0;  // κ̂ alone there: simplification's edge set, EDGE without the noise
};

// EDGE where κ̂ less noise reaches the threshold.
EdgeCounts FlagEdges(PointCloud& cloud, const std::vector<float>& curvature,
                     const std::vector<float>& beyond_noise, double threshold) {
  EdgeCounts counts;
  for (size_t i = 0; i < cloud.size(); ++i) {
    cloud.flags[i] &= static_cast<uint8_t>(~kEdge);
    if (cloud.removed(i)) continue;
    counts.at_threshold += curvature[i] >= threshold;
    if (beyond_noise[i] >= threshold) {
      cloud.flags[i] |= kEdge;
      ++counts.flagged;
    }
  }
  return counts;
}

absl::Status Curvature(PointCloud& cloud, PointMeasures& m, const Neighbourhoods* nb,
                       const MeasuresSettings& settings, StageReporter& out) {
  const size_t n = cloud.size();
  SCANPREP_ASSIGN_OR_RETURN(const std::vector<double> window, Windows(cloud, nb, settings, out));
  ScanlineCurvatures scanline;
  SCANPREP_ASSIGN_OR_RETURN(const bool lines, ScanlineStep(cloud, window, out, scanline));
  const NoiseBounds bounds(nb ? nb->k() : kDefaultNeighbourK);
  SCANPREP_ASSIGN_OR_RETURN(const std::vector<float> median_fit,
                            MedianFitPerScan(cloud, m, bounds, out.cancel()));
  std::vector<float>& curvature = m.curvature;
  curvature.assign(n, 0.f);
  std::vector<float> beyond_noise(n, 0.f);
  std::atomic<size_t> fallback{0};
  const auto by_line = [&](size_t i) { return lines && std::isfinite(scanline.kappa[i]); };
  // Neither a scanline window nor a normal fit: no curvature at all.
  const auto unknown = [&](size_t i) { return !by_line(i) && !HasNormal(cloud, i); };
  SCANPREP_RETURN_IF_ERROR(ParallelFor(n, out.cancel(), [&](size_t begin, size_t end) {
    size_t local_fallback = 0;
    for (size_t i = begin; i < end; ++i) {
      if (cloud.removed(i) || unknown(i)) continue;
      const double median = median_fit[cloud.scan[i]];
      const Judged judged =
          by_line(i) ? FromScanline(scanline, i, bounds.sigma_per_median * median, settings)
                     : FromVariation(m, i, median, bounds.fit_ms_over_median, settings);
      local_fallback += !by_line(i);
      curvature[i] = static_cast<float>(std::min(judged.curvature, 1.0));  // Eq. (7)
      beyond_noise[i] = static_cast<float>(std::min(judged.beyond_noise, 1.0));
    }
    fallback += local_fallback;
  }));
  AssignScanMedians(cloud, unknown, curvature);
  const EdgeCounts edges = FlagEdges(cloud, curvature, beyond_noise, settings.edge_threshold);
  out.Record("measures.edges", static_cast<double>(edges.flagged));
  out.Record("measures.curvature_at_threshold", static_cast<double>(edges.at_threshold));
  out.Record("measures.curvature_from_variation", static_cast<double>(fallback));
  return absl::OkStatus();
}

class MeasuresStage : public Stage {
 public:
  absl::Status Run(StageContext& ctx) override {
    return ComputeMeasures(ctx.cloud(), ctx.measures(), ctx.neighbourhoods().value_or(nullptr),
                           ctx.Settings(MeasuresParams()), ctx.out());
  }
};

}  // namespace

absl::Status ComputeMeasures(PointCloud& cloud, PointMeasures& m, const Neighbourhoods* nb,
                             const MeasuresSettings& settings, StageReporter& out) {
  if (m.fit_rms.size() != cloud.size() || m.surface_variation.size() != cloud.size()) {
    return absl::InternalError("measures: the normals stage left no fits");
  }
  SCANPREP_RETURN_IF_ERROR(Quality(cloud, m, out));
  return Curvature(cloud, m, nb, settings, out);
}

const ParamTable<MeasuresSettings>& MeasuresParams() {
  using S = MeasuresSettings;
  static const ParamTable<S> table = {
      param::Real(&S::scale, "measures.curvature_scale_per_mm", 0.2, LeftOpen(0, 1000),
                  "s: scanline curvature of a significant edge"),
      param::Real(&S::variation_scale, "measures.variation_scale", 0.02, LeftOpen(0, 1),
                  "s_σ: surface variation of a significant edge (fallback without scanlines)"),
      param::Real(&S::edge_threshold, "measures.edge_threshold", 0.5, Closed(0, 1),
                  "κ̂ at or above which a point is flagged as an edge"),
      param::DerivedReal(&S::window, "measures.window_mm",
                         "max(3Δp, 2u, (1215·u²·Δp/s²)^(1/5)) per scan", LeftOpen(0, 1e4),
                         "half-width h of the scanline curvature window"),
  };
  return table;
}

StageInfo MeasuresStageInfo() {
  return {
      .name = std::string(stage_names::kMeasures),
      .summary = "viewing quality q̂ and normalised curvature κ̂ per point (Eq. 7); edge flags",
      .params = MeasuresParams().Specs(),
      .make = [] { return std::make_unique<MeasuresStage>(); },
      .prerequisites =
          [](const ParamOverrides&) { return stage_names::List({stage_names::kNormals}); },
      .work_per_point = 2,
      .cost_weight = 0.65,
  };
}

}  // namespace scanprep
