// SPDX-License-Identifier: Apache-2.0
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

TEST(ScanSimulator, SteppedBlockSurfaceQueries) {
  const Part part = Part::kSteppedBlock;
  // The slot (|x| < 3, floor at z = 5) is open above: its floor, walls and rims are the surface.
  EXPECT_NEAR(DistanceToSurface(part, {0, 0, 6}), 1.0, 1e-12);
  EXPECT_TRUE(SurfaceNormal(part, {0, 0, 6}).isApprox(Eigen::Vector3d::UnitZ()));
  EXPECT_NEAR(DistanceToSurface(part, {2.5, 0, 6.5}), 0.5, 1e-12);
  EXPECT_TRUE(SurfaceNormal(part, {2.5, 0, 6.5}).isApprox(-Eigen::Vector3d::UnitX()));
  EXPECT_TRUE(SurfaceNormal(part, {-2.5, 0, 6.5}).isApprox(Eigen::Vector3d::UnitX()));
  EXPECT_NEAR(DistanceToSurface(part, {11, 5, 8.2}), 0.2, 1e-12);
  EXPECT_NEAR(DistanceToSurface(part, {0, 0, 9}), std::sqrt(10.0), 1e-12);  // to the rims
  EXPECT_NEAR(DistanceToSurface(part, {0, 9, 4}), 1.0, 1e-12);              // end face, below
  EXPECT_NEAR(DistanceToSurface(part, {0, 9, 6}), std::sqrt(2.0), 1e-12);   // the notch's floor
  EXPECT_NEAR(DistanceToSurface(part, {-12.5, 0, 4}), 0.5, 1e-12);
  // The bore (radius 2 at x = 7.5, y = 0): its wall faces the axis; above it, its rim is nearest.
  EXPECT_NEAR(DistanceToSurface(part, {8.5, 0, 4}), 1.0, 1e-12);
  EXPECT_TRUE(SurfaceNormal(part, {8.5, 0, 4}).isApprox(-Eigen::Vector3d::UnitX()));
  EXPECT_TRUE(SurfaceNormal(part, {7.5, 1.5, 4}).isApprox(-Eigen::Vector3d::UnitY()));
  EXPECT_NEAR(DistanceToSurface(part, {7.5, 0.5, 8.5}), std::hypot(1.5, 0.5), 1e-12);
  EXPECT_NEAR(DistanceToSurface(part, {7.5, 3.0, 8.5}), 0.5, 1e-12);  // the top beside it
}

TEST(ScanSimulator, SteppedBlockRaysStopAtTheFirstFaceTheyMeet) {
  // A noise-free laser straight down (+z above the block's centre): inside the slot every ray
  // must reach the floor, outside it the top.
  SimSensor frontal = FrontalSensor(Part::kPlane)[0];
  frontal.camera_position += Eigen::Vector3d(0, 0, 4);
  frontal.laser_position += Eigen::Vector3d(0, 0, 4);
  frontal.noise_sigma = 0;
  const SimulatedCloud sim = Simulate(Part::kSteppedBlock, {frontal}, 1);
  size_t floor = 0, top = 0;
  for (size_t i = 0; i < sim.cloud.size(); ++i) {
    const Eigen::Vector3f t = sim.truth[i];
    ASSERT_NEAR(DistanceToSurface(Part::kSteppedBlock, t.cast<double>()), 0.0, 1e-4);
    ASSERT_GT(std::hypot(t.x() - 7.5f, t.y()), 2.0f - 1e-4f) << "rays down the bore hit nothing";
    if (std::abs(t.x()) < 2.9f && std::abs(t.y()) < 7.9f) {
      ASSERT_NEAR(t.z(), 5.0f, 1e-4f) << "inside the slot the ray must reach its floor";
      ++floor;
    }
    if (std::abs(t.x()) > 3.1f && t.z() > 4.0f) {
      ASSERT_NEAR(t.z(), 8.0f, 1e-4f);
      ++top;
    }
  }
  EXPECT_GT(floor, 1000u);
  EXPECT_GT(top, 5000u);
}

TEST(ScanSimulator, SteppedBlockTellsConvexFromConcaveEdges) {
  const Part part = Part::kSteppedBlock;
  const SimulatedCloud sim = Simulate(part, ThreeOverlappingSensors(part), 5);
  const Stats s = Measure(part, sim, 0.01);
  EXPECT_EQ(s.far, 0u);
  ASSERT_EQ(sim.edge_convex.size(), sim.cloud.size());
  size_t wall_facing_x = 0, wall_facing_minus_x = 0, bore = 0, concave = 0, convex = 0;
  size_t per_scan[3] = {0, 0, 0};
  for (size_t i = 0; i < sim.cloud.size(); ++i) {
    const Eigen::Vector3f t = sim.truth[i], n = sim.true_normal[i];
    ++per_scan[sim.cloud.scan[i]];
    wall_facing_x += n.x() > 0.99f && std::abs(t.x() + 3) < 1e-4f;
    wall_facing_minus_x += n.x() < -0.99f && std::abs(t.x() - 3) < 1e-4f;
    bore += std::abs(n.z()) < 0.01f && std::abs(std::hypot(t.x() - 7.5f, t.y()) - 2) < 1e-4f;
    const bool mid = std::abs(t.y()) < 7.5f;  // away from the end faces' edges
    const float to_wall = std::abs(std::abs(t.x()) - 3.0f);
    // On the floor or a wall next to their meeting line: concave; on the top next to a rim or
    // on a wall next to it: convex.
    if (mid && to_wall < 0.15f && std::abs(t.z() - 5) < 1e-4f) {
      ASSERT_EQ(sim.edge_convex[i], 0) << t.transpose();
      ASSERT_NEAR(sim.edge_distance[i], to_wall, 1e-4f);
    }
    const bool on_wall = mid && to_wall < 1e-4f;
    if (on_wall && t.z() < 5.15f) {
      ASSERT_EQ(sim.edge_convex[i], 0) << t.transpose();
    }
    if ((on_wall && t.z() > 7.85f) || (mid && to_wall < 0.15f && std::abs(t.z() - 8) < 1e-4f)) {
      ASSERT_EQ(sim.edge_convex[i], 1) << t.transpose();
    }
    if (sim.edge_distance[i] < 0.2f) ++(sim.edge_convex[i] ? convex : concave);
  }
  std::printf(
      "stepped block: %zu points (%zu/%zu/%zu per scan), slot walls %zu/%zu, bore %zu, "
      "within 0.2 mm of a convex edge %zu, of a concave edge %zu\n",
      sim.cloud.size(), per_scan[0], per_scan[1], per_scan[2], wall_facing_x, wall_facing_minus_x,
      bore, convex, concave);
  // Every sensor sees the top; each side sensor sees the wall facing it and the concave edge at
  // its foot.
  for (size_t n : per_scan) EXPECT_GT(n, 10000u);
  EXPECT_GT(wall_facing_x, 500u);
  EXPECT_GT(wall_facing_minus_x, 500u);
  EXPECT_GT(bore, 300u);
  EXPECT_GT(concave, 200u);
  EXPECT_GT(convex, 1000u);
  EXPECT_EQ(sim.cloud.scans.size(), 3u);
  for (const ScanMeta& m : sim.cloud.scans) EXPECT_DOUBLE_EQ(m.uncertainty, 3 * 0.01);
}

}  // namespace
}  // namespace scanprep::testing
