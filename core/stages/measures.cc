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
#include "core/spatial/median_nearest.h"
#include "core/stages/scanline_curvature.h"
#include "core/stages/stage_context.h"

namespace scanprep {

std::optional<Eigen::Vector3d> TowardCamera(const ScanMeta& scan, const Eigen::Vector3d& p) {
  if (scan.camera_position) return *scan.camera_position - p;
  if (scan.view_direction) return *scan.view_direction;
  return std::nullopt;
}

double ViewAngle(const Eigen::Vector3d& n, const Eigen::Vector3d& toward) {
  const double norm = toward.norm();
  if (!(norm > 0)) return 0;
  return std::acos(std::clamp(std::abs(n.dot(toward)) / norm, 0.0, 1.0));
}

namespace {

std::optional<Eigen::Vector3d> TowardProjector(const ScanMeta& scan, const Eigen::Vector3d& p) {
  if (scan.projector_position) return *scan.projector_position - p;
  if (scan.projector_direction) return *scan.projector_direction;
  return std::nullopt;
}

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

// The curvature half's parameters, read once at its start.
struct CurvatureSettings {
  double scale;                  // s: scanline curvature of a significant edge
  double variation_scale;        // s_σ: surface variation of one (fallback without scanlines)
  double edge_threshold;         // κ̂ at or above which a point is an edge
  std::optional<double> window;  // h for every scan, else derived per scan
};

CurvatureSettings ReadCurvatureSettings(StageContext& ctx) {
  return {.scale = ctx.Number(kMeasuresCurvatureScale),
          .variation_scale = ctx.Number(kMeasuresVariationScale),
          .edge_threshold = ctx.Number(kMeasuresEdgeThreshold),
          .window = ctx.Overridden(kMeasuresWindow)};
}

class MeasuresStage : public Stage {
 public:
  absl::Status Run(StageContext& ctx) override {
    SCANPREP_RETURN_IF_ERROR(Quality(ctx));
    return Curvature(ctx);
  }

 private:
  static absl::Status Quality(StageContext& ctx) {
    const PointCloud& cloud = ctx.cloud();
    const size_t n = cloud.size();
    std::vector<float>& quality = ctx.measures().quality;
    quality.assign(n, 1.f);
    if (cloud.quality.size() == n) {
      ctx.Record("measures.quality_from_scanner", 1);
      return ParallelFor(n, ctx.cancel(), [&](size_t begin, size_t end) {
        for (size_t i = begin; i < end; ++i) {
          quality[i] =
              std::isfinite(cloud.quality[i]) ? std::clamp(cloud.quality[i], 0.f, 1.f) : 0.f;
        }
      });
    }
    ctx.Record("measures.quality_from_scanner", 0);
    size_t without_pose = 0;
    for (size_t s = 0; s < cloud.scans.size(); ++s) {
      const ScanMeta& scan = cloud.scans[s];
      if (!TowardCamera(scan, Eigen::Vector3d::Zero()) &&
          !TowardProjector(scan, Eigen::Vector3d::Zero())) {
        ++without_pose;
        ctx.Warn(WarningCode::kNoPose,
                 absl::StrCat("measures: scan '", scan.id,
                              "' has neither sensor poses nor a "
                              "per-point quality; its viewing quality is set to 1"));
      }
    }
    ctx.Record("measures.scans_without_pose", static_cast<double>(without_pose));
    SCANPREP_RETURN_IF_ERROR(ParallelFor(n, ctx.cancel(), [&](size_t begin, size_t end) {
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

  static absl::Status Curvature(StageContext& ctx) {
    PointCloud& cloud = ctx.cloud();
    const size_t n = cloud.size();
    const CurvatureSettings settings = ReadCurvatureSettings(ctx);

    SCANPREP_ASSIGN_OR_RETURN(const std::vector<double> spacing, ScanPointSpacing(ctx));
    std::vector<double> window(cloud.scans.size(), 0.0);
    for (size_t s = 0; s < cloud.scans.size(); ++s) {
      const double u = cloud.scans[s].uncertainty;
      window[s] = settings.window.value_or(
          std::max({3 * spacing[s], 2 * u, NoiseWindow(u, spacing[s], settings.scale)}));
      ctx.RecordForScan("measures.point_spacing_mm", s, spacing[s]);
      ctx.RecordForScan(kMeasuresWindow, s, window[s]);
    }

    std::vector<float> kappa;
    const bool lines = cloud.kind == ScannerKind::kLine && cloud.has_scanlines();
    // A line scanner's κ̂ comes from its scanlines (Eq. 11); without them every point falls back
    // to surface variation (Eq. 12), which blurs edges over the whole ball. Flexible scanners
    // have no scanlines by design, so only a line scan that lost them is warned about.
    const bool line_scan_without_scanlines = cloud.kind == ScannerKind::kLine && !lines;
    ctx.Record("measures.line_scan_without_scanlines", line_scan_without_scanlines ? 1 : 0);
    if (line_scan_without_scanlines) {
      ctx.Warn(WarningCode::kNoScanlines,
               "measures: the line scans came without scanline indices, so curvature κ̂ is "
               "surface variation (Eq. 12) everywhere instead of scanline curvature (Eq. 11); "
               "send the scanline of every point");
    }
    if (lines) {
      ScanlineCurvatureCounts counts;
      SCANPREP_RETURN_IF_ERROR(ScanlineCurvature(cloud, window, ctx.cancel(), kappa, counts));
      ctx.Record("measures.windows_capped", static_cast<double>(counts.windows_capped));
      if (counts.windows_capped > 0) {
        ctx.Warn(WarningCode::kWindowsCapped,
                 absl::StrCat("measures: ", counts.windows_capped,
                              " scanline windows held more "
                              "than ",
                              kMaxWindowSide,
                              " points on a side and were cut to that; "
                              "measures.window_mm may be far too large for the point spacing "
                              "(or given in the wrong unit)"));
      }
    }
    std::vector<float>& curvature = ctx.measures().curvature;
    curvature.assign(n, 0.f);
    const std::vector<float>& variation = ctx.measures().surface_variation;
    std::atomic<size_t> fallback{0};
    // Neither a scanline window nor a normal fit: no curvature at all.
    auto unknown = [&](size_t i) {
      return !(lines && std::isfinite(kappa[i])) && !HasNormal(cloud, i);
    };
    SCANPREP_RETURN_IF_ERROR(ParallelFor(n, ctx.cancel(), [&](size_t begin, size_t end) {
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
    ctx.Record("measures.edges", static_cast<double>(edges));
    ctx.Record("measures.curvature_from_variation", static_cast<double>(fallback));
    return absl::OkStatus();
  }
};

}  // namespace

absl::StatusOr<std::vector<double>> ScanPointSpacing(StageContext& ctx) {
  const PointCloud& cloud = ctx.cloud();
  SCANPREP_ASSIGN_OR_RETURN(std::vector<double> spacing,
                            MedianScanlineSpacing(cloud, ctx.cancel()));
  auto nb = ctx.neighbourhoods();
  std::vector<bool> unknown(spacing.size());
  for (size_t s = 0; s < spacing.size(); ++s) {
    if (spacing[s] == 0) spacing[s] = cloud.scans[s].point_spacing;
    unknown[s] = spacing[s] == 0;
  }
  if (!nb.ok() || (*nb)->k() == 0) return spacing;
  SCANPREP_ASSIGN_OR_RETURN(const std::vector<double> measured,
                            MedianNearestDistance(cloud, **nb, ctx.cancel(), unknown));
  for (size_t s = 0; s < spacing.size(); ++s) {
    if (unknown[s]) spacing[s] = measured[s];
  }
  return spacing;
}

StageInfo MeasuresStageInfo() {
  return {
      .name = "measures",
      .summary = "viewing quality q̂ and normalised curvature κ̂ per point (Eq. 7); edge flags",
      .params =
          {
              RealParam(kMeasuresCurvatureScale, "s: scanline curvature of a significant edge", 0.2,
                        LeftOpen(0, 1000)),
              RealParam(kMeasuresVariationScale,
                        "s_σ: surface variation of a significant "
                        "edge (fallback without scanlines)",
                        0.02, LeftOpen(0, 1)),
              RealParam(kMeasuresEdgeThreshold, "κ̂ at or above which a point is flagged as an edge",
                        0.5, Closed(0, 1)),
              DerivedRealParam(kMeasuresWindow,
                               "half-width h of the scanline curvature "
                               "window",
                               "max(3Δp, 2u, (1215·u²·Δp/s²)^(1/5)) per scan", LeftOpen(0, 1e4)),
          },
      .make = [] { return std::make_unique<MeasuresStage>(); },
      .prerequisites = [](const ParamOverrides&) { return std::vector<std::string>{"normals"}; },
      .work_per_point = 2,
      .cost_weight = 0.65,
  };
}

bool UniformQuality(const PointCloud& cloud, const std::vector<float>& quality) {
  std::optional<float> first;
  for (size_t i = 0; i < cloud.size(); ++i) {
    if (cloud.removed(i)) continue;
    if (!first) first = quality[i];
    if (quality[i] != *first) return false;
  }
  return true;
}

}  // namespace scanprep
