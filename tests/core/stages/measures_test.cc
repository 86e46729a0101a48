// SPDX-License-Identifier: Apache-2.0
// Viewing quality and curvature against the simulator's ground truth.
#include <cstdio>
#include <functional>
#include <numbers>
#include <random>

#include <gtest/gtest.h>

#include "core/base/status_macros.h"
#include "core/pipeline/pipeline.h"
#include "core/sim/scan_simulator.h"
#include "core/stages/measures.h"
#include "core/stages/scanline_curvature.h"
#include "tests/support/metrology_job.h"
#include "tests/support/planned_stages.h"
#include "tests/support/sim_checks.h"
#include "tests/support/stage_call.h"

namespace scanprep::testing {
using namespace scanprep::sim;
namespace {

// The stage function, called on the normals its plan's earlier stages fitted, after `before` has
// seen the cloud; its measures copied into `result`.
// `stages`: the plan it is part of (default: measures alone, after its prerequisites).
absl::StatusOr<PipelineReport> RunMeasures(PointCloud& cloud, PointMeasures* result,
                                           const ParamOverrides& params = {},
                                           const std::function<void(PointCloud&)>& before = {},
                                           std::vector<std::string> stages = {}) {
  return CallStage(
      cloud, "measures", params,
      [&](StageInputs& in) {
        if (before) before(in.cloud);
        SCANPREP_RETURN_IF_ERROR(ComputeMeasures(in.cloud, in.measures, &in.neighbourhoods,
                                                 in.Settings(MeasuresParams()), in.out));
        *result = in.measures;
        return absl::OkStatus();
      },
      std::move(stages));
}

double Angle(const Eigen::Vector3d& n, const Eigen::Vector3d& toward) {
  return std::acos(std::min(1.0, std::abs(n.dot(toward.normalized()))));
}

TEST(Measures, QualityFollowsTheViewingAngleOnATiltedPlane) {
  double previous = 2;
  for (double tilt_deg : {0.0, 20.0, 40.0, 55.0}) {
    auto sensors = FrontalSensor(Part::kPlane);
    const double t = tilt_deg * std::numbers::pi / 180;
    // Tilt the whole sensor about x, away from the camera side: q = 25° + tilt.
    const Eigen::AngleAxisd rot(-t, Eigen::Vector3d::UnitX());
    sensors[0].laser_position = rot * sensors[0].laser_position;
    sensors[0].camera_position = rot * sensors[0].camera_position;
    SimulatedCloud sim = Simulate(Part::kPlane, sensors, 21);
    PointMeasures m;
    ASSERT_TRUE(RunMeasures(sim.cloud, &m).ok());
    std::vector<double> error, values;
    const ScanMeta& scan = sim.cloud.scans[0];
    for (size_t i = 0; i < sim.cloud.size(); ++i) {
      const Eigen::Vector3d p = sim.truth[i].cast<double>(), n = sim.true_normal[i].cast<double>();
      const double q =
          std::max(Angle(n, *scan.camera_position - p), Angle(n, *scan.projector_direction));
      error.push_back(std::abs(m.quality[i] - (1 - q / (std::numbers::pi / 2))));
      values.push_back(m.quality[i]);
    }
    const double median = Quantile(values, 0.5);
    std::printf("tilt %4.1f°: median q̂ %.4f, |q̂ − (1 − q/(π/2))| median %.5f, p99 %.5f\n", tilt_deg,
                median, Quantile(error, 0.5), Quantile(error, 0.99));
    // A 2° normal error moves q̂ by at most 2/90 = 0.022.
    EXPECT_LT(Quantile(error, 0.5), 0.01);
    EXPECT_LT(Quantile(error, 0.99), 0.03);
    EXPECT_LT(median, previous);
    previous = median;
  }
}

TEST(Measures, WithoutPosesQualityIsOneAndWarns) {
  SimulatedCloud sim = Simulate(Part::kPlane, FrontalSensor(Part::kPlane), 22);
  sim.cloud.scans[0].camera_position.reset();
  sim.cloud.scans[0].projector_direction.reset();
  PointMeasures m;
  auto report = RunMeasures(sim.cloud, &m);
  ASSERT_TRUE(report.ok());
  for (float q : m.quality) ASSERT_EQ(q, 1.f);
  EXPECT_FALSE(report->warnings.empty());

  sim.cloud.quality.assign(sim.cloud.size(), 0.25f);
  sim.cloud.quality[0] = 7.f;
  ASSERT_TRUE(RunMeasures(sim.cloud, &m).ok());
  EXPECT_EQ(m.quality[0], 1.f);
  EXPECT_EQ(m.quality[1], 0.25f);
}

// A point whose normal could not be fitted has neither a viewing angle nor a surface variation:
// it gets its scan's median q̂ and κ̂, not the best weight (q̂ = 1, κ̂ = 0) that would let it win
// every merge. No scanlines here, so κ̂ comes from the normal fit too.
TEST(Measures, PointsWithoutANormalGetTheirScansMedianNotTheBestWeight) {
  auto sensors = FrontalSensor(Part::kPlane);
  const Eigen::AngleAxisd rot(-40 * std::numbers::pi / 180, Eigen::Vector3d::UnitX());
  sensors[0].laser_position = rot * sensors[0].laser_position;
  sensors[0].camera_position = rot * sensors[0].camera_position;
  SimulatedCloud sim = Simulate(Part::kPlane, sensors, 23);
  PointCloud& cloud = sim.cloud;
  cloud.scanline.clear();
  std::vector<size_t> lost;
  PointMeasures m;
  ASSERT_TRUE(RunMeasures(cloud, &m, {}, [&](PointCloud& fitted) {
                for (size_t i = 0; i < fitted.size(); i += 97) {
                  fitted.flags[i] |= kNormalInvalid;
                  lost.push_back(i);
                }
              }).ok());
  std::vector<double> quality, curvature;
  for (size_t i = 0; i < cloud.size(); ++i) {
    if (cloud.flags[i] & kNormalInvalid) continue;
    quality.push_back(m.quality[i]);
    curvature.push_back(m.curvature[i]);
  }
  const double q_median = Quantile(quality, 0.5), k_median = Quantile(curvature, 0.5);
  ASSERT_LT(q_median, 0.8);  // a tilted view: q̂ = 1 would stand out
  ASSERT_GT(k_median, 0);    // noise gives a flat plane some surface variation
  for (size_t i : lost) {
    EXPECT_NEAR(m.quality[i], q_median, 1e-3) << i;
    EXPECT_NEAR(m.curvature[i], k_median, 1e-3) << i;
  }
}

TEST(Measures, PlaneIsFlatAndSpacingIsMeasured) {
  SimulatedCloud sim = Simulate(Part::kPlane, FrontalSensor(Part::kPlane), 23);
  PointMeasures m;
  auto report = RunMeasures(sim.cloud, &m);
  ASSERT_TRUE(report.ok());
  std::vector<double> k(m.curvature.begin(), m.curvature.end());
  const auto& params = report->stages.back().parameters;
  std::printf("plane: κ̂ p50 %.4f p99 %.4f, Δp %.4f mm, window %.3f mm, fallback %.0f\n",
              Quantile(k, 0.5), Quantile(k, 0.99), params.at("measures.point_spacing_mm"),
              params.at("measures.window_mm"), params.at("measures.curvature_from_variation"));
  EXPECT_LT(Quantile(k, 0.99), 0.5);
  EXPECT_NEAR(params.at("measures.point_spacing_mm"), 0.1, 0.005);
}

struct EdgeHits {
  size_t edge_points = 0, edge_hits = 0, rim_points = 0, rim_hits = 0, far = 0, far_hits = 0;
};

// κ̂ ≥ 0.5 and the edge flag within Δs of the box's visible straight edges (top/+x, top/+y and
// the vertical +x/+y one), on the bore's rim, and on faces more than 2 mm from any edge.
EdgeHits BoxEdgeHits(SimulatedCloud& sim) {
  PointMeasures m;
  EXPECT_TRUE(RunMeasures(sim.cloud, &m).ok());
  const double ds = sim.cloud.scans[0].scanline_spacing;
  using G = PartGeometry;
  EdgeHits h;
  for (size_t i = 0; i < sim.cloud.size(); ++i) {
    const Eigen::Vector3f t = sim.truth[i];
    const bool hit = m.curvature[i] >= 0.5f && (sim.cloud.flags[i] & kEdge);
    if (sim.edge_distance[i] > 2.0f) {
      ++h.far;
      h.far_hits += hit;
      continue;
    }
    if (sim.edge_distance[i] > ds) continue;
    const bool near_x = std::abs(t.x() - G::box_half_x) < ds,
               near_y = std::abs(t.y() - G::box_half_y) < ds,
               near_top = std::abs(t.z() - G::box_height) < ds;
    if ((near_top && (near_x || near_y)) || (near_x && near_y)) {
      ++h.edge_points;
      h.edge_hits += hit;
    } else if (std::abs(t.head<2>().norm() - G::bore_radius) < ds) {
      ++h.rim_points;
      h.rim_hits += hit;
    }
  }
  return h;
}

TEST(Measures, SharpBoxEdgesReachTheEdgeThreshold) {
  SimulatedCloud sim = Simulate(Part::kBoxWithBore, FrontalSensor(Part::kBoxWithBore), 24);
  const EdgeHits h = BoxEdgeHits(sim);
  std::printf(
      "box: %zu/%zu points within Δs of visible straight edges have κ̂ >= 0.5; bore rim "
      "%zu/%zu; faces > 2 mm from edges %zu/%zu\n",
      h.edge_hits, h.edge_points, h.rim_hits, h.rim_points, h.far_hits, h.far);
  ASSERT_GT(h.edge_points, 100u);
  EXPECT_GE(h.edge_hits, 0.9 * h.edge_points);
  EXPECT_LE(h.far_hits, 0.02 * h.far);
}

// Without scanlines (a flexible scanner) κ̂ is the surface variation over s_σ (Eq. 12): a 90°
// crease has variation ≈ 0.09 in a ball centred on it, so its points reach κ̂ = 1, while a face's
// noise stays far below s_σ / 2 = 0.01. Unscaled, no variation would reach the threshold.
TEST(Measures, SurfaceVariationFindsTheBoxEdgesWithoutScanlines) {
  SimulatedCloud sim = Simulate(Part::kBoxWithBore, FrontalSensor(Part::kBoxWithBore), 24);
  sim.cloud.scanline.clear();
  sim.cloud.kind = ScannerKind::kFlexible;
  const EdgeHits h = BoxEdgeHits(sim);
  std::printf("box without scanlines: straight edges %zu/%zu, bore rim %zu/%zu, faces %zu/%zu\n",
              h.edge_hits, h.edge_points, h.rim_hits, h.rim_points, h.far_hits, h.far);
  ASSERT_GT(h.edge_points, 100u);
  EXPECT_GE(h.edge_hits, 0.9 * h.edge_points);
  EXPECT_LE(h.far_hits, 0.02 * h.far);
}

// Straight scanlines with Gaussian noise σ across them: κ = |2·a2|/(1 + a1²)^1.5 is then |a
// Gaussian| whose standard deviation the fit states per unit σ (noise_per_sigma), so the RMS of
// κ over the windows is σ times that. Ground truth is the spread the noise really produced.
TEST(Measures, ScanlineCurvatureStatesTheSpreadNoiseGivesIt) {
  constexpr int kLines = 40, kPoints = 500;
  constexpr double kSigma = 0.01;
  std::mt19937_64 rng(31);
  std::normal_distribution<double> noise(0, kSigma);
  PointCloud cloud;
  for (int line = 0; line < kLines; ++line) {
    for (int t = 0; t < kPoints; ++t) {
      cloud.x.push_back(0.05f * t);
      cloud.y.push_back(0.2f * line);
      cloud.z.push_back(static_cast<float>(noise(rng)));
      cloud.scanline.push_back(line);
    }
  }
  cloud.scans.push_back(ScanMeta{.id = "lines", .scanline_spacing = 0.2, .uncertainty = kSigma});
  cloud.FinishLoading();
  ScanlineCurvatures c;
  ScanlineCurvatureCounts counts;
  ASSERT_TRUE(ScanlineCurvature(cloud, {0.5}, CancelToken(), c, counts).ok());
  double sum_sq = 0;
  std::vector<double> stated;
  for (size_t i = 0; i < cloud.size(); ++i) {
    if (!std::isfinite(c.kappa[i])) continue;
    sum_sq += double(c.kappa[i]) * c.kappa[i];
    stated.push_back(kSigma * c.noise_per_sigma[i]);
  }
  ASSERT_GT(stated.size(), size_t{kLines * (kPoints - 20)});
  const double rms = std::sqrt(sum_sq / double(stated.size()));
  std::printf("straight noisy lines: κ RMS %.4f /mm, stated %.4f /mm\n", rms,
              Quantile(stated, 0.5));
  EXPECT_NEAR(rms / Quantile(stated, 0.5), 1.0, 0.1);
}

// The EDGE flag knows the noise (§9 "Noise"): on the faces of a part seen by three oblique
// laser-line sensors, where the noise grows with the viewing angle, noise alone must not make an
// edge. The control is the rule without the noise term (κ̂ >= 0.5), which calls a good share of
// the same faces edges; the sharp edges themselves stay flagged
// (SharpBoxEdgesReachTheEdgeThreshold).
struct FaceFlags {
  double flagged = 0, without_noise_term = 0;
};
FaceFlags FlagsFarFromEdges(Part part, double sigma, bool metadata) {
  const SimulatedCloud sim = SimulateScan(part, sigma, 60000, 77);
  PointCloud cloud = metadata ? WithUserMetadata(sim, sigma) : WithoutMetadata(sim);
  PointMeasures m;
  // After the outliers, as in a job: a spike kinks every scanline window it falls in.
  EXPECT_TRUE(RunMeasures(cloud, &m, {}, {}, {"outliers", "measures"}).ok());
  size_t far = 0, flagged = 0, raw = 0;
  for (size_t i = 0; i < cloud.size(); ++i) {
    if (sim.is_outlier[i] || cloud.removed(i) || sim.edge_distance[i] <= 3.0f) continue;
    ++far;
    flagged += (cloud.flags[i] & kEdge) != 0;
    raw += m.curvature[i] >= 0.5f;
  }
  EXPECT_GT(far, 5000u);
  return {double(flagged) / double(far), double(raw) / double(far)};
}

TEST(Measures, NoiseAloneMakesNoEdgeOnTheFacesOfAPart) {
  for (const Part part : {Part::kSteppedBlock, Part::kBoxWithBore}) {
    for (const double sigma : {0.01, 0.03}) {
      const FaceFlags f = FlagsFarFromEdges(part, sigma, true);
      std::printf(
          "part %d, σ %.2f: %.1f %% of points > 3 mm from an edge flagged (%.1f %% "
          "without the noise term)\n",
          int(part), sigma, 100 * f.flagged, 100 * f.without_noise_term);
      EXPECT_LE(f.flagged, 0.04) << int(part) << " " << sigma;
      EXPECT_LE(f.flagged, 0.3 * f.without_noise_term) << int(part) << " " << sigma;
    }
  }
}

// The fallback (no scanlines, no poses: one bare .xyz) judges surface variation against the
// cloud's own fit residuals: one band of q̂, so the oblique faces' noise is less well known.
TEST(Measures, NoiseAloneMakesFewEdgesWithoutMetadata) {
  for (const Part part : {Part::kSteppedBlock, Part::kBoxWithBore}) {
    const FaceFlags f = FlagsFarFromEdges(part, 0.03, false);
    std::printf("part %d without metadata: %.1f %% flagged (%.1f %% without the noise term)\n",
                int(part), 100 * f.flagged, 100 * f.without_noise_term);
    EXPECT_LE(f.flagged, 0.07) << int(part);
    EXPECT_GE(f.without_noise_term, 0.5) << int(part);
  }
}

// A bore of radius 2 mm (κ = 0.5 mm⁻¹, κ̂ = 1) scanned across its axis with noise σ: curvature far
// beyond noise, but a smooth one: a quadratic plus noise explains every window, so nothing on it
// is an edge. The control is κ̂ itself, which calls the whole wall significant curvature.
TEST(Measures, ASmoothCurvedFaceIsNoEdge) {
  constexpr double kRadius = 2, kSigma = 0.005, kStep = 0.05;
  std::mt19937_64 rng(43);
  std::normal_distribution<double> noise(0, kSigma);
  PointCloud cloud;
  for (int line = 0; line < 40; ++line) {
    for (double a = -1.3; a <= 1.3; a += kStep / kRadius) {
      const double r = kRadius + noise(rng);
      cloud.x.push_back(static_cast<float>(r * std::cos(a)));
      cloud.y.push_back(static_cast<float>(r * std::sin(a)));
      cloud.z.push_back(0.1f * line);
      cloud.scanline.push_back(line);
    }
  }
  cloud.scans.push_back(ScanMeta{.id = "bore",
                                 .camera_position = Eigen::Vector3d(50, 0, 2),
                                 .scanline_spacing = 0.1,
                                 .uncertainty = kSigma,
                                 .point_spacing = kStep});
  cloud.FinishLoading();
  PointMeasures m;
  ASSERT_TRUE(RunMeasures(cloud, &m).ok());
  size_t edges = 0, curved = 0;
  for (size_t i = 0; i < cloud.size(); ++i) {
    edges += (cloud.flags[i] & kEdge) != 0;
    curved += m.curvature[i] >= 0.5f;
  }
  std::printf("bore wall: %zu of %zu points EDGE, %zu with κ̂ >= 0.5\n", edges, cloud.size(),
              curved);
  EXPECT_LE(edges, cloud.size() / 50);
  EXPECT_GE(curved, cloud.size() * 9 / 10);
}

TEST(Measures, ScanlineCurvatureOfACylinderIsOneOverR) {
  SimulatedCloud sim = Simulate(Part::kCylinder, FrontalSensor(Part::kCylinder), 25);
  PointMeasures m;
  auto report = RunMeasures(sim.cloud, &m);
  ASSERT_TRUE(report.ok());
  const double s = report->stages.back().parameters.at("measures.curvature_scale_per_mm");
  std::vector<double> kappa;
  for (size_t i = 0; i < sim.cloud.size(); ++i) {
    // Lines run across the axis; stay away from the silhouettes where the line ends.
    if (std::abs(sim.true_normal[i].x()) < 0.5f) kappa.push_back(m.curvature[i] * s);
  }
  const double median = Quantile(kappa, 0.5);
  std::printf(
      "cylinder R=%.0f: %zu points, scanline κ median %.4f (1/R = %.4f), p10 %.4f, p90 "
      "%.4f\n",
      PartGeometry::cylinder_radius, kappa.size(), median, 1 / PartGeometry::cylinder_radius,
      Quantile(kappa, 0.1), Quantile(kappa, 0.9));
  EXPECT_NEAR(median, 1 / PartGeometry::cylinder_radius, 0.1 / PartGeometry::cylinder_radius);
}

// Five full circles of radius R = 159 mm as scanlines, 20,000 points each, 0.05 mm apart.
PointCloud Rings() {
  PointCloud cloud;
  constexpr int kLines = 5, kPoints = 20000;
  constexpr double kRadius = kPoints * 0.05 / (2 * std::numbers::pi);
  for (int line = 0; line < kLines; ++line) {
    for (int t = 0; t < kPoints; ++t) {
      const double a = 2 * std::numbers::pi * t / kPoints;
      cloud.x.push_back(static_cast<float>(kRadius * std::cos(a)));
      cloud.y.push_back(static_cast<float>(kRadius * std::sin(a)));
      cloud.z.push_back(0.2f * line);
      cloud.scanline.push_back(line);
    }
  }
  cloud.scans.push_back(ScanMeta{.id = "rings", .scanline_spacing = 0.2, .uncertainty = 0.01});
  cloud.FinishLoading();
  return cloud;
}

// A window far beyond the data (1e9 mm, as a window given in the wrong unit would be) is cut to
// kMaxWindowSide points a side: the work stays O(n·K) instead of O(L²) per line. A 1 mm window
// (20 points a side) is not cut, and gives κ = 1/R.
TEST(Measures, ScanlineWindowIsBoundedWhateverItsWidth) {
  PointCloud cloud = Rings();
  const double radius = 20000 * 0.05 / (2 * std::numbers::pi);
  const size_t n = cloud.size();
  CancelToken cancel;
  ScanlineCurvatures curvatures;
  const std::vector<float>& kappa = curvatures.kappa;
  ScanlineCurvatureCounts huge;
  ASSERT_TRUE(ScanlineCurvature(cloud, {1e9}, cancel, curvatures, huge).ok());
  std::printf("window 1e9 mm: %zu windows capped, %zu window points (%.1f per point)\n",
              huge.windows_capped, huge.window_points, double(huge.window_points) / n);
  EXPECT_LE(huge.window_points, (2 * kMaxWindowSide + 1) * n);
  EXPECT_EQ(huge.windows_capped, n - 5 * 4);  // all but the two points at each line end

  ScanlineCurvatureCounts fitting;
  ASSERT_TRUE(ScanlineCurvature(cloud, {1.0}, cancel, curvatures, fitting).ok());
  EXPECT_EQ(fitting.windows_capped, 0u);
  std::vector<double> relative;
  for (size_t i = 0; i < n; ++i) {
    if (std::isfinite(kappa[i])) relative.push_back(std::abs(kappa[i] * radius - 1));
  }
  std::printf("window 1 mm: κ·R − 1 median %.5f, max %.5f over %zu points\n",
              Quantile(relative, 0.5), Quantile(relative, 1.0), relative.size());
  EXPECT_GE(relative.size(), n - 5 * 40);  // all but 20 points at each line end
  EXPECT_LT(Quantile(relative, 1.0), 0.02);
}

// One scanline over a step: a flat run at z = 0, an unseen 0.5 mm (5·Δp) stretch where the step's
// face is occluded, and a flat run 0.3 mm higher. Both runs are straight, so every curvature the
// line yields must be 0; a 1 mm window that fitted across the gap would bend over the step.
TEST(Measures, ScanlinesAreSplitAtGaps) {
  PointCloud cloud;
  for (int t = 0; t < 60; ++t) {
    const bool upper = t >= 30;
    cloud.x.push_back(0.1f * t + (upper ? 0.4f : 0.f));
    cloud.y.push_back(0.f);
    cloud.z.push_back(upper ? 0.3f : 0.f);
    cloud.scanline.push_back(0);
  }
  cloud.scans.push_back(ScanMeta{.id = "step", .scanline_spacing = 0.2, .uncertainty = 0.01});
  cloud.FinishLoading();
  CancelToken cancel;
  ScanlineCurvatures curvatures;
  ScanlineCurvatureCounts counts;
  ASSERT_TRUE(ScanlineCurvature(cloud, {1.0}, cancel, curvatures, counts).ok());
  size_t fitted = 0;
  float largest = 0;
  for (const float k : curvatures.kappa) {
    if (!std::isfinite(k)) continue;
    ++fitted;
    largest = std::max(largest, k);
  }
  EXPECT_EQ(fitted, 60u - 4 * 2);  // all but the two points at each end of each run
  EXPECT_LT(largest, 1e-3f);
}

TEST(Measures, CappedScanlineWindowsAreReported) {
  PointCloud cloud = Rings();
  PointMeasures m;
  auto report = RunMeasures(cloud, &m, {{"measures.window_mm", "10000"}});  // the most admitted
  ASSERT_TRUE(report.ok()) << report.status();
  EXPECT_GT(report->stages.back().parameters.at("measures.windows_capped"), 0);
  bool warned = false;
  for (const Warning& w : report->warnings) warned |= w.code == WarningCode::kWindowsCapped;
  EXPECT_TRUE(warned);
}

}  // namespace
}  // namespace scanprep::testing
