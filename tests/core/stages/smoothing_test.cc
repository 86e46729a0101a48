// SPDX-License-Identifier: Apache-2.0
// Smoothing against the simulator's true surfaces. Default method (own side): noise drops to well
// under half on flat parts and sharp box edges get closer to the truth, not rounder; the noise is
// measured from the data. The paper's method (mean): Eq. (10)'s δ = u is what keeps its edges.
// Each weight and guard has a test that compares against ground truth with it and without it.
#include <cmath>

#include <gtest/gtest.h>

#include "core/pipeline/pipeline.h"
#include "core/sim/scan_simulator.h"
#include "core/stages/smoothing.h"
#include "tests/support/stage_call.h"

namespace scanprep {
namespace {

using sim::Part;

// RMS distance to the true surface over the points `select` accepts.
template <typename Select>
double RmsToSurface(Part part, const PointCloud& cloud, Select select) {
  double sum = 0;
  size_t count = 0;
  for (size_t i = 0; i < cloud.size(); ++i) {
    if (!select(i)) continue;
    const double d = sim::DistanceToSurface(part, cloud.point(i).cast<double>());
    sum += d * d;
    ++count;
  }
  EXPECT_GT(count, 100u);
  return std::sqrt(sum / std::max<size_t>(count, 1));
}

// The stage function, called on the inputs its plan's earlier stages built.
absl::StatusOr<PipelineReport> RunSmoothing(PointCloud& cloud, const ParamOverrides& params = {}) {
  return testing::CallStage(cloud, "smoothing", params, [](testing::StageInputs& in) {
    return Smooth(in.cloud, in.measures, in.neighbourhoods, in.Settings(SmoothingParams()), in.out);
  });
}

float LongestMove(const PointCloud& before, const PointCloud& after) {
  float longest = 0;
  for (size_t i = 0; i < after.size(); ++i) {
    longest = std::max(longest, (after.point(i) - before.point(i)).norm());
  }
  return longest;
}

bool HasWarning(const PipelineReport& report, std::string_view text) {
  for (const Warning& w : report.warnings) {
    if (w.message.find(text) != std::string::npos) return true;
  }
  return false;
}

// The box of the edge tests, scanned frontally, with its zones by distance to the true edges.
struct BoxScan {
  sim::SimulatedCloud sim;
  float spacing;
  explicit BoxScan(uint64_t seed)
      : sim(sim::Simulate(Part::kBoxWithBore, sim::FrontalSensor(Part::kBoxWithBore), seed)),
        spacing(static_cast<float>(sim.cloud.scans[0].scanline_spacing)) {}
  auto NearEdge() const {
    return [this](size_t i) { return sim.edge_distance[i] <= spacing; };
  }
  auto Flat() const {
    return [this](size_t i) { return sim.edge_distance[i] > 2.0f; };
  }
  double Rms(const PointCloud& cloud, auto select) const {
    return RmsToSurface(Part::kBoxWithBore, cloud, select);
  }
};

TEST(Smoothing, LowersNoiseOnAPlaneAndMeasuresIt) {
  auto sim = sim::Simulate(Part::kPlane, sim::FrontalSensor(Part::kPlane), 11);
  PointCloud& cloud = sim.cloud;
  // Away from the border, where a neighbourhood is one-sided.
  auto interior = [&](size_t i) {
    return std::abs(sim.truth[i].x()) < 9 && std::abs(sim.truth[i].y()) < 9;
  };
  const double before = RmsToSurface(Part::kPlane, cloud, interior);
  auto report = RunSmoothing(cloud);
  ASSERT_TRUE(report.ok()) << report.status();
  const double after = RmsToSurface(Part::kPlane, cloud, interior);
  std::printf("plane RMS to true surface: before %.4f mm, after %.4f mm (%.0f %% lower)\n", before,
              after, 100 * (1 - after / before));
  EXPECT_LE(after, 0.4 * before);
  const auto& params = report->stages.back().parameters;
  EXPECT_GT(params.at("smoothing.moved"), 0.95 * cloud.size());
  // The measured noise is the true one (the raw RMS), not the stated u = 3σ.
  const double noise = params.at("smoothing.noise_mm");
  EXPECT_GT(noise, 0.8 * before);
  EXPECT_LT(noise, 1.1 * before);
  EXPECT_NEAR(params.at("smoothing.tolerance_mm"), 3 * noise, 1e-6);
  EXPECT_DOUBLE_EQ(params.at("smoothing.lambda"), 0.5);
  EXPECT_FALSE(HasWarning(*report, "noisier"));
}

TEST(Smoothing, SharpensTheEdgesOfABox) {
  BoxScan box(12);
  PointCloud& cloud = box.sim.cloud;
  const PointCloud original = cloud;
  const double edge_before = box.Rms(cloud, box.NearEdge());
  const double flat_before = box.Rms(cloud, box.Flat());
  auto report = RunSmoothing(cloud);
  ASSERT_TRUE(report.ok()) << report.status();
  const double edge_after = box.Rms(cloud, box.NearEdge());
  const double flat_after = box.Rms(cloud, box.Flat());
  const double noise = report->stages.back().parameters.at("smoothing.noise_mm");
  std::printf("box: edge RMS %.4f -> %.4f mm, flat RMS %.4f -> %.4f mm, σ̂ %.4f mm\n", edge_before,
              edge_after, flat_before, flat_after, noise);
  EXPECT_LE(edge_after, 0.75 * edge_before);
  EXPECT_LE(flat_after, 0.4 * flat_before);
  // No move is longer than 3 local σ, and a local σ is at most twice the scan's.
  EXPECT_LE(LongestMove(original, cloud), 3 * 2 * noise * (1 + 1e-4));

  // It is the own-side plane, not δ, that keeps the edge: with δ far above any move it still
  // sharpens, where the paper's mean (control) rounds the edge off.
  PointCloud own_unguarded = original, mean_unguarded = original;
  ASSERT_TRUE(RunSmoothing(own_unguarded, {{"smoothing.tolerance_mm", "10"}}).ok());
  ASSERT_TRUE(
      RunSmoothing(mean_unguarded, {{"smoothing.method", "mean"}, {"smoothing.tolerance_mm", "10"}})
          .ok());
  const double own_edge = box.Rms(own_unguarded, box.NearEdge());
  const double mean_edge = box.Rms(mean_unguarded, box.NearEdge());
  std::printf("box, δ = 10 mm: edge RMS own side %.4f, mean %.4f mm\n", own_edge, mean_edge);
  EXPECT_LE(own_edge, 0.8 * edge_before);
  EXPECT_GT(mean_edge, 1.1 * edge_before);
}

TEST(Smoothing, PaperMeanKeepsEdgesByRejectingMovesLongerThanU) {
  BoxScan box(13);
  PointCloud& cloud = box.sim.cloud;
  const PointCloud original = cloud;
  const double edge_before = box.Rms(cloud, box.NearEdge());
  const double flat_before = box.Rms(cloud, box.Flat());
  auto report = RunSmoothing(cloud, {{"smoothing.method", "mean"}});
  ASSERT_TRUE(report.ok()) << report.status();
  const double u = cloud.scans[0].uncertainty;
  const auto& params = report->stages.back().parameters;
  EXPECT_NEAR(params.at("smoothing.tolerance_mm"), u, 1e-6);
  EXPECT_EQ(params.count("smoothing.noise_mm"), 0u);
  EXPECT_LE(LongestMove(original, cloud), u * (1 + 1e-4));
  EXPECT_LE(box.Rms(cloud, box.NearEdge()), 1.1 * edge_before);
  EXPECT_LE(box.Rms(cloud, box.Flat()), 0.75 * flat_before);
  EXPECT_GT(params.at("smoothing.rejected"), 0);
}

// Eq. (6)'s flatness term: at an edge the mean must lean on the flat faces around it, not on the
// edge's own (curved, high-κ̂) points, or it cuts the edge off. Control: λ = 1 (quality only).
TEST(Smoothing, FlatnessWeightKeepsEdgePointsOnTheEdge) {
  BoxScan box(15);
  auto near = box.NearEdge();
  const double before = box.Rms(box.sim.cloud, near);
  auto mean_with_lambda = [&](const char* lambda) {
    PointCloud cloud = box.sim.cloud;
    EXPECT_TRUE(RunSmoothing(cloud, {{"smoothing.method", "mean"},
                                     {"smoothing.tolerance_mm", "10"},
                                     {"smoothing.lambda", lambda}})
                    .ok());
    return box.Rms(cloud, near);
  };
  const double flatness = mean_with_lambda("0"), quality = mean_with_lambda("1");
  std::printf("at edges: raw %.4f, λ = 0 %.4f, λ = 1 %.4f mm\n", before, flatness, quality);
  EXPECT_LT(flatness, 0.6 * quality);
}

// Φ (Fig. 3): the farther the weight reaches, the more a mean cuts into a curved surface. On a
// sphere the Gaussian fall-off shrinks it least, no fall-off most; the cubic lies between.
TEST(Smoothing, FallOffSetsHowFarAMeanCutsIntoACurvedSurface) {
  const auto sim = sim::Simulate(Part::kSphere, sim::FrontalSensor(Part::kSphere), 16);
  auto shrinkage = [&](const char* influence) {
    PointCloud cloud = sim.cloud;
    EXPECT_TRUE(RunSmoothing(cloud, {{"smoothing.method", "mean"},
                                     {"smoothing.tolerance_mm", "10"},
                                     {"smoothing.influence", influence}})
                    .ok());
    double sum = 0;
    for (size_t i = 0; i < cloud.size(); ++i) {
      sum += sim::PartGeometry::sphere_radius - cloud.point(i).cast<double>().norm();
    }
    return sum / static_cast<double>(cloud.size());
  };
  const double gauss = shrinkage("gauss"), cubic = shrinkage("cubic"),
               average = shrinkage("average");
  std::printf("sphere shrinkage: gauss %.5f, cubic %.5f, average %.5f mm\n", gauss, cubic, average);
  EXPECT_GT(gauss, 0);
  EXPECT_LT(gauss, 0.9 * cubic);
  EXPECT_LT(cubic, 0.9 * average);
}

// Eq. (6)'s quality term: where a frontal and a twice-as-noisy oblique scan overlap, weighting by
// q̂ fits the plane mostly to the better scan. Control: λ = 0 (flatness only).
TEST(Smoothing, QualityWeightFavoursTheBetterViewedScan) {
  const auto sim = sim::Simulate(Part::kPlane, sim::TwoOverlappingSensors(Part::kPlane), 17);
  auto interior = [&](size_t i) {
    return std::abs(sim.truth[i].x()) < 9 && std::abs(sim.truth[i].y()) < 9;
  };
  auto own_side_with_lambda = [&](const char* lambda) {
    PointCloud cloud = sim.cloud;
    EXPECT_TRUE(RunSmoothing(cloud, {{"smoothing.lambda", lambda}}).ok());
    return RmsToSurface(Part::kPlane, cloud, interior);
  };
  const double quality = own_side_with_lambda("1"), flatness = own_side_with_lambda("0");
  std::printf("overlap: raw %.4f, λ = 1 %.4f, λ = 0 %.4f mm\n",
              RmsToSurface(Part::kPlane, sim.cloud, interior), quality, flatness);
  EXPECT_LT(quality, 0.95 * flatness);
}

TEST(Smoothing, WarnsWhenTheDataIsFarNoisierThanItsStatedUncertainty) {
  auto sim = sim::Simulate(Part::kPlane, sim::FrontalSensor(Part::kPlane), 18);
  PointCloud control = sim.cloud;
  sim.cloud.scans[0].uncertainty = 0.001;  // 1 µm stated, 10 µm measured: a unit or u slip
  auto report = RunSmoothing(sim.cloud);
  ASSERT_TRUE(report.ok()) << report.status();
  EXPECT_TRUE(HasWarning(*report, "noisier"));
  auto control_report = RunSmoothing(control);
  ASSERT_TRUE(control_report.ok()) << control_report.status();
  EXPECT_FALSE(HasWarning(*control_report, "noisier"));
}

TEST(Smoothing, AFixedNoiseSetsTheGatesAndTheMoveLimit) {
  auto sim = sim::Simulate(Part::kPlane, sim::FrontalSensor(Part::kPlane), 19);
  const PointCloud original = sim.cloud;
  auto report = RunSmoothing(sim.cloud, {{"smoothing.noise_mm", "0.001"}});
  ASSERT_TRUE(report.ok()) << report.status();
  const auto& params = report->stages.back().parameters;
  EXPECT_DOUBLE_EQ(params.at("smoothing.noise_mm"), 0.001);
  // 10 µm noise judged in 1 µm σ: many points find no plane within 3 µm or a longer move,
  // and none moves farther than 3 local σ.
  EXPECT_LE(LongestMove(original, sim.cloud), 3 * 2 * 0.001 * (1 + 1e-4));
  EXPECT_GT(params.at("smoothing.unfitted") + params.at("smoothing.rejected"),
            0.15 * sim.cloud.size());
}

TEST(Smoothing, ClampModeNeverMovesFartherThanTheTolerance) {
  BoxScan box(14);
  PointCloud& cloud = box.sim.cloud;
  const PointCloud original = cloud;
  auto report = RunSmoothing(cloud, {{"smoothing.tolerance", "clamp"},
                                     {"smoothing.tolerance_mm", "0.005"},
                                     {"smoothing.iterations", "2"}});
  ASSERT_TRUE(report.ok()) << report.status();
  size_t flagged = 0;
  for (size_t i = 0; i < cloud.size(); ++i) flagged += (cloud.flags[i] & kSmoothed) != 0;
  const float longest = LongestMove(original, cloud);
  EXPECT_LE(longest, 2 * 0.005f * (1 + 1e-4));  // two passes of at most δ each
  EXPECT_GT(longest, 0.005f);
  const auto& params = report->stages.back().parameters;
  EXPECT_EQ(params.at("smoothing.rejected"), 0);
  EXPECT_GT(params.at("smoothing.clamped"), 0);
  EXPECT_GT(flagged, cloud.size() / 2);
}

TEST(Smoothing, RejectsALambdaOutsideTheUnitInterval) {
  auto sim = sim::Simulate(Part::kPlane, sim::FrontalSensor(Part::kPlane), 14);
  auto report = RunSmoothing(sim.cloud, {{"smoothing.lambda", "1.5"}});
  EXPECT_EQ(report.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(report.status().message().find("smoothing.lambda"), std::string::npos);
}

}  // namespace
}  // namespace scanprep
