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

absl::Status Curvature(PointCloud& cloud, PointMeasures& m, const Neighbourhoods* nb,
                       const MeasuresSettings& settings, StageReporter& out) {
  const size_t n = cloud.size();
  SCANPREP_ASSIGN_OR_RETURN(const std::vector<double> window, Windows(cloud, nb, settings, out));

  std::vector<float> kappa;
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
  if (lines) {
    ScanlineCurvatureCounts counts;
    SCANPREP_RETURN_IF_ERROR(ScanlineCurvature(cloud, window, out.cancel(), kappa, counts));
    out.Record("measures.windows_capped", static_cast<double>(counts.windows_capped));
    if (counts.windows_capped > 0) {
      out.Warn(WarningCode::kWindowsCapped,
               absl::StrCat("measures: ", counts.windows_capped,
                            " scanline windows held more "
                            "than ",
                            kMaxWindowSide,
                            " points on a side and were cut to that; "
                            "measures.window_mm may be far too large for the point spacing "
                            "(or given in the wrong unit)"));
    }
  }
  std::vector<float>& curvature = m.curvature;
  curvature.assign(n, 0.f);
  const std::vector<float>& variation = m.surface_variation;
  std::atomic<size_t> fallback{0};
  // Neither a scanline window nor a normal fit: no curvature at all.
  auto unknown = [&](size_t i) {
    return !(lines && std::isfinite(kappa[i])) && !HasNormal(cloud, i);
  };
  SCANPREP_RETURN_IF_ERROR(ParallelFor(n, out.cancel(), [&](size_t begin, size_t end) {
    size_t local_fallback = 0;
    for (size_t i = begin; i < end; ++i) {
      if (cloud.removed(i)) continue;
      double value;
      if (lines && std::isfinite(kappa[i])) {
        value = kappa[i] / settings.scale;
      } else {
        value = variation[i] / settings.variation_scale;  // Eq. (12) fallback
        ++local_fallback;
      }
      curvature[i] = static_cast<float>(std::min(value, 1.0));  // Eq. (7)
    }
    fallback += local_fallback;
  }));
  AssignScanMedians(cloud, unknown, curvature);
  size_t edges = 0;
  for (size_t i = 0; i < n; ++i) {
    cloud.flags[i] &= static_cast<uint8_t>(~kEdge);
    if (!cloud.removed(i) && curvature[i] >= settings.edge_threshold) {
      cloud.flags[i] |= kEdge;
      ++edges;
    }
  }
  out.Record("measures.edges", static_cast<double>(edges));
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
