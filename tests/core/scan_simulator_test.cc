// The simulator's ground truth must be trustworthy before other tests lean on it.
#include "core/sim/scan_simulator.h"

#include <algorithm>
#include <cmath>

#include <gtest/gtest.h>

namespace scanprep::testing {
using namespace scanprep::sim;
namespace {

struct Stats {
  size_t count = 0, outliers = 0, far = 0;
  double rms = 0;
};

// Distance of every non-spike sample to the true surface, and how many exceed 5·(3σ/cos 80°).
Stats Measure(Part part, const SimulatedCloud& sim, double sigma) {
  Stats s;
  s.count = sim.cloud.size();
  for (size_t i = 0; i < s.count; ++i) {
    const Eigen::Vector3d p = sim.cloud.point(i).cast<double>();
    EXPECT_LT((sim.truth[i].cast<double>() - p).norm(), 25 * sigma / std::cos(1.4) + 0.05);
    EXPECT_NEAR(DistanceToSurface(part, sim.truth[i].cast<double>()), 0.0, 1e-3);
    EXPECT_NEAR(sim.true_normal[i].norm(), 1.0f, 1e-5f);
    if (sim.is_outlier[i]) {
      ++s.outliers;
      continue;
    }
    const double d = DistanceToSurface(part, p);
    s.rms += d * d;
    if (d > 5 * sigma / std::cos(80 * M_PI / 180)) ++s.far;
  }
  s.rms = std::sqrt(s.rms / std::max<size_t>(1, s.count - s.outliers));
  return s;
}

TEST(ScanSimulator, PlaneSamplesLieOnTheSurfaceWithTheConfiguredNoise) {
  auto sensors = FrontalSensor(Part::kPlane);
  sensors[0].noise_sigma = 0.02;
  const SimulatedCloud sim = Simulate(Part::kPlane, sensors, 1);
  const Stats s = Measure(Part::kPlane, sim, 0.02);
  // 20 × 20 mm at 0.2 × 0.1 mm spacing: 20,000 samples.
  EXPECT_NEAR(static_cast<double>(s.count), 20000.0, 500.0);
  EXPECT_EQ(s.outliers, 0u);
  EXPECT_EQ(s.far, 0u);
  // Noise along the camera ray at ≈25° from the normal: σ/cos(25°) along the ray, σ along z.
  EXPECT_NEAR(s.rms, 0.02, 0.002);
  EXPECT_EQ(sim.cloud.scans.size(), 1u);
  EXPECT_TRUE(sim.cloud.scans[0].camera_position.has_value());
  EXPECT_DOUBLE_EQ(sim.cloud.scans[0].scanline_spacing, 0.2);
  // Scanlines are in order, points advance along each line.
  for (size_t i = 1; i < sim.cloud.size(); ++i) {
    ASSERT_GE(sim.cloud.scanline[i], sim.cloud.scanline[i - 1]);
  }
}

TEST(ScanSimulator, OnlyVisibleSurfaceIsSampled) {
  const SimulatedCloud sim = Simulate(Part::kSphere, FrontalSensor(Part::kSphere), 2);
  const Eigen::Vector3d cam = *sim.cloud.scans[0].camera_position;
  for (size_t i = 0; i < sim.cloud.size(); ++i) {
    const Eigen::Vector3d t = sim.truth[i].cast<double>();
    ASSERT_GT(sim.true_normal[i].cast<double>().dot(cam - t), 0.0);
    ASSERT_GT(t.z(), 0.0);
  }
  // The visible cap of a 10 mm sphere up to 80° from both directions: well below πR²/0.02.
  EXPECT_GT(sim.cloud.size(), 8000u);
  EXPECT_LT(sim.cloud.size(), 15708u);
}

TEST(ScanSimulator, BoxShowsThreeFacesTheBoreAndItsEdges) {
  const SimulatedCloud sim = Simulate(Part::kBoxWithBore, FrontalSensor(Part::kBoxWithBore), 3);
  const Stats s = Measure(Part::kBoxWithBore, sim, 0.01);
  EXPECT_EQ(s.far, 0u);
  size_t top = 0, side_x = 0, side_y = 0, bore = 0, near_edge = 0;
  for (size_t i = 0; i < sim.cloud.size(); ++i) {
    const Eigen::Vector3f n = sim.true_normal[i];
    top += n.z() > 0.99f;
    side_x += n.x() > 0.99f;
    side_y += n.y() > 0.99f;
    bore += std::abs(n.z()) < 0.01f && std::abs(sim.truth[i].head<2>().norm() - 3.0f) < 1e-3f;
    near_edge += sim.edge_distance[i] < 0.2f;
  }
  std::printf("box: %zu points, top %zu, +x %zu, +y %zu, bore %zu, near edge %zu\n",
              sim.cloud.size(), top, side_x, side_y, bore, near_edge);
  EXPECT_GT(top, 5000u);
  EXPECT_GT(side_x, 1000u);
  EXPECT_GT(side_y, 500u);
  EXPECT_GT(bore, 100u);
  EXPECT_GT(near_edge, 200u);
}

TEST(ScanSimulator, OverlappingScansAndSpikes) {
  auto sensors = TwoOverlappingSensors(Part::kCylinder);
  for (auto& s : sensors) s.outlier_fraction = 0.01;
  const SimulatedCloud sim = Simulate(Part::kCylinder, sensors, 4);
  const Stats s = Measure(Part::kCylinder, sim, 0.02);
  EXPECT_EQ(sim.cloud.scans.size(), 2u);
  EXPECT_NEAR(static_cast<double>(s.outliers) / s.count, 0.01, 0.003);
  size_t per_scan[2] = {0, 0};
  for (uint32_t sc : sim.cloud.scan) ++per_scan[sc];
  EXPECT_GT(per_scan[0], 10000u);
  EXPECT_GT(per_scan[1], 5000u);
  // Spikes sit at least 5σ (σ at frontal view) off the surface.
  for (size_t i = 0; i < sim.cloud.size(); ++i) {
    if (sim.is_outlier[i]) {
      EXPECT_GE((sim.cloud.point(i) - sim.truth[i]).norm(), 5 * 0.01 - 0.021);
    }
  }
  // Deterministic for a seed.
  const SimulatedCloud again = Simulate(Part::kCylinder, sensors, 4);
  EXPECT_EQ(again.cloud.x, sim.cloud.x);
}

TEST(ScanSimulator, SurfaceQueries) {
  EXPECT_NEAR(DistanceToSurface(Part::kSphere, {0, 0, 12}), 2.0, 1e-12);
  EXPECT_NEAR(DistanceToSurface(Part::kBoxWithBore, {0, 0, 4}), 3.0, 1e-12);
  EXPECT_TRUE(SurfaceNormal(Part::kBoxWithBore, {0, 2.5, 4}).isApprox(Eigen::Vector3d(0, -1, 0)));
  EXPECT_TRUE(SurfaceNormal(Part::kBoxWithBore, {5, 0, 8.1}).isApprox(Eigen::Vector3d::UnitZ()));
  EXPECT_NEAR(DistanceToSurface(Part::kCylinder, {0, 3, -11}), 1.0, 1e-12);
}

}  // namespace
}  // namespace scanprep::testing
