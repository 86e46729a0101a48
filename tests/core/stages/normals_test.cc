// SPDX-License-Identifier: Apache-2.0
// Normals against the simulator's ground truth: accuracy on flat and curved regions, orientation
// toward the sensor (Eq. 3) and consistent spanning-tree orientation without poses (Eq. 5).
#include <cstdio>
#include <numbers>

#include <gtest/gtest.h>

#include "core/io/ply.h"
#include "core/sim/scan_simulator.h"
#include "tests/support/normals_call.h"
#include "tests/support/sim_checks.h"
#include "tests/support/test_data.h"

namespace scanprep::testing {
using namespace scanprep::sim;
namespace {

struct NormalCheck {
  double median_deg = 0, p95_deg = 0;
  size_t checked = 0, invalid = 0, away_from_sensor = 0;
};

// Angles to the true normal for points passing `use`, and how many face away from their scan's
// camera.
template <typename Use>
NormalCheck Check(const SimulatedCloud& sim, Use use) {
  const PointCloud& cloud = sim.cloud;
  NormalCheck c;
  std::vector<double> angles;
  for (size_t i = 0; i < cloud.size(); ++i) {
    if (!use(i)) continue;
    if (cloud.flags[i] & kNormalInvalid) {
      ++c.invalid;
      continue;
    }
    angles.push_back(AxisAngleDeg(cloud, i, sim.true_normal[i]));
    const auto& cam = cloud.scans[cloud.scan[i]].camera_position;
    if (cam && cloud.normal(i).cast<double>().dot(*cam - cloud.point(i).cast<double>()) <= 0) {
      ++c.away_from_sensor;
    }
  }
  c.checked = angles.size();
  c.median_deg = Quantile(angles, 0.5);
  c.p95_deg = Quantile(angles, 0.95);
  return c;
}

TEST(Normals, PlaneWithinTwoDegreesAndFacingTheSensor) {
  SimulatedCloud sim = Simulate(Part::kPlane, FrontalSensor(Part::kPlane), 11);
  auto report = testing::RunNormalsFunction(sim.cloud);
  ASSERT_TRUE(report.ok()) << report.status();
  const NormalCheck c = Check(sim, [](size_t) { return true; });
  std::printf("plane: %zu normals, median %.3f°, p95 %.3f°, invalid %zu, away %zu\n", c.checked,
              c.median_deg, c.p95_deg, c.invalid, c.away_from_sensor);
  EXPECT_LT(c.median_deg, 2.0);
  EXPECT_EQ(c.away_from_sensor, 0u);
  EXPECT_EQ(c.invalid, 0u);
  ASSERT_EQ(sim.cloud.nx.size(), sim.cloud.size());
  EXPECT_EQ(report->stages.back().parameters.at("normals.oriented_toward_sensor"),
            static_cast<double>(sim.cloud.size()));
  // Surface variation of a noisy plane stays far below the 90° crease value (≈ 0.09).
  EXPECT_EQ(report->stages.back().name, "normals");
}

// A laser-line sensor whose profiles lie far apart next to its point pitch (conveyor speed against
// camera resolution): at 0.01 mm along a line and 1 mm between lines, d_k and r_g are 0.1 mm, all
// k nearest on the point's own line, so only r_min (Eq. 2, √3·Δs + ε_u) reaches the next
// profile. Held to 3·r_g every ball held one profile, whose noisy line fits as a "plane" standing
// on edge: every normal 90° off, none invalid. The stated spacing is borne out by the data (its
// measured scanline gap) and kept; the ball is the capped nearest of r_min, not the one-line k-NN
// list. Control: the same sensor at 0.1 mm between lines, where 3·r_g reaches the next line.
TEST(Normals, ProfilesAHundredPointSpacingsApartGiveTheSurfaceNormal) {
  for (const double scanline_spacing : {0.1, 1.0}) {
    std::vector<SimSensor> sensors = FrontalSensor(Part::kPlane);
    sensors[0].scanline_spacing = scanline_spacing;
    sensors[0].point_spacing = 0.01;
    sensors[0].noise_sigma = 0.003;
    SimulatedCloud sim = Simulate(Part::kPlane, sensors, 12);
    auto report = testing::RunNormalsFunction(sim.cloud);
    ASSERT_TRUE(report.ok()) << report.status();
    const NormalCheck c = Check(sim, [](size_t) { return true; });
    std::printf(
        "profiles %.1f mm apart, points 0.01 mm: %zu normals, median %.3f°, p95 %.3f°, "
        "invalid %zu\n",
        scanline_spacing, c.checked, c.median_deg, c.p95_deg, c.invalid);
    EXPECT_LT(c.median_deg, 2.0) << "Δs " << scanline_spacing;
    EXPECT_LT(c.p95_deg, 5.0) << "Δs " << scanline_spacing;
    EXPECT_EQ(c.invalid, 0u) << "Δs " << scanline_spacing;
  }
}

TEST(Normals, BoxFacesAwayFromEdges) {
  SimulatedCloud sim = Simulate(Part::kBoxWithBore, FrontalSensor(Part::kBoxWithBore), 12);
  ASSERT_TRUE(testing::RunNormalsFunction(sim.cloud).ok());
  const NormalCheck faces = Check(sim, [&](size_t i) { return sim.edge_distance[i] > 1.0f; });
  const NormalCheck all = Check(sim, [](size_t) { return true; });
  std::printf(
      "box faces (>1 mm from edges): %zu normals, median %.3f°, p95 %.3f°; all points: "
      "median %.3f°, p95 %.3f°, away %zu\n",
      faces.checked, faces.median_deg, faces.p95_deg, all.median_deg, all.p95_deg,
      all.away_from_sensor);
  EXPECT_LT(faces.median_deg, 2.0);
  EXPECT_LT(faces.p95_deg, 5.0);
  EXPECT_EQ(all.away_from_sensor, 0u);
}

TEST(Normals, CylinderNormalsFollowTheCurvedSurface) {
  SimulatedCloud sim = Simulate(Part::kCylinder, FrontalSensor(Part::kCylinder), 13);
  ASSERT_TRUE(testing::RunNormalsFunction(sim.cloud).ok());
  const NormalCheck c = Check(sim, [](size_t) { return true; });
  std::printf("cylinder R=10: %zu normals, median %.3f°, p95 %.3f°, away %zu\n", c.checked,
              c.median_deg, c.p95_deg, c.away_from_sensor);
  EXPECT_LT(c.median_deg, 2.0);
  EXPECT_EQ(c.away_from_sensor, 0u);
}

TEST(Normals, MitraRadiusModeIsAccurateToo) {
  SimulatedCloud sim = Simulate(Part::kCylinder, FrontalSensor(Part::kCylinder), 14);
  auto report = testing::RunNormalsFunction(sim.cloud, {{"normals.radius_mode", "mitra"}});
  ASSERT_TRUE(report.ok()) << report.status();
  const NormalCheck c = Check(sim, [](size_t) { return true; });
  const double r = report->stages.back().parameters.at("normals.median_radius_mm");
  std::printf("cylinder, Mitra radius: median r %.3f mm, median %.3f°, p95 %.3f°\n", r,
              c.median_deg, c.p95_deg);
  EXPECT_LT(c.median_deg, 2.0);
  // Eq. (1) with σ = u = 0.03, ρ ≈ 50/mm², κ = 0.1: r ≈ 0.6 mm, clamped to [r_min, 5 r_g].
  EXPECT_GT(r, 0.4);
  EXPECT_LT(r, 2.5);
}

// Eq. (1): r = ((c1·σ/√(ε·ρ) + c2·σ²) / κ)^(1/3). On one surface (same σ, ρ, κ) and with c2·σ²
// small beside c1·σ/√(ε·ρ) (0.0009 vs 0.019 here), ten times c1 makes the radius 10^(1/3) = 2.15
// times longer: measured 2.23 (κ is estimated a little high in the smaller balls); a square root
// would make it 3.2 times (measured 3.5).
TEST(Normals, MitraRadiusGrowsAsTheCubeRootOfC1) {
  double radius[2];
  for (const int c1 : {1, 10}) {
    SimulatedCloud sim = Simulate(Part::kCylinder, FrontalSensor(Part::kCylinder), 14);
    auto report = testing::RunNormalsFunction(
        sim.cloud, {{"normals.radius_mode", "mitra"}, {"normals.mitra_c1", std::to_string(c1)}});
    ASSERT_TRUE(report.ok()) << report.status();
    radius[c1 == 10] = report->stages.back().parameters.at("normals.median_radius_mm");
    // Both radii well inside the clamp [r_floor, mitra_max_radius_mm]: the formula decides.
    ASSERT_LT(radius[c1 == 10],
              0.9 * report->stages.back().parameters.at("normals.mitra_max_radius_mm"));
  }
  std::printf("Mitra median radius: c1 = 1: %.3f mm, c1 = 10: %.3f mm (ratio %.2f)\n", radius[0],
              radius[1], radius[1] / radius[0]);
  EXPECT_GT(radius[1] / radius[0], 1.9);
  EXPECT_LT(radius[1] / radius[0], 2.5);
}

// §6: a point's normal is fitted to its own scan only. The oblique scan is misregistered by a 4°
// rotation, so its points lie on a plane 4° off the frontal scan's: fitted together, the overlap's
// normals would split the difference; each scan's normals must follow its own plane.
TEST(Normals, OverlappingScansUseTheirOwnPoints) {
  std::vector<SimSensor> sensors = TwoOverlappingSensors(Part::kPlane);
  const Eigen::Matrix3d tilt =
      Eigen::AngleAxisd(4 * std::numbers::pi / 180, Eigen::Vector3d::UnitX()).toRotationMatrix();
  sensors[1].misregistration.linear() = tilt;
  SimulatedCloud sim = Simulate(Part::kPlane, sensors, 15);
  for (size_t i = 0; i < sim.cloud.size(); ++i) {
    if (sim.cloud.scan[i] != 1) continue;
    sim.true_normal[i] = (tilt * sim.true_normal[i].cast<double>()).cast<float>();
  }
  ASSERT_TRUE(testing::RunNormalsFunction(sim.cloud).ok());
  for (uint32_t s = 0; s < 2; ++s) {
    const NormalCheck c = Check(sim, [&](size_t i) { return sim.cloud.scan[i] == s; });
    std::printf("overlap, scan %u: %zu normals, median %.3f°, p95 %.3f°, away %zu\n", s, c.checked,
                c.median_deg, c.p95_deg, c.away_from_sensor);
    // The oblique scan has 2× the noise at 45°, ≈2.8× the frontal σ along its rays. Measured p95
    // 1.9° and 4.1°; with the other scan's points in the fit, 5.9° and 10.3°.
    EXPECT_LT(c.median_deg, s == 0 ? 2.0 : 2.5);
    EXPECT_LT(c.p95_deg, s == 0 ? 3.0 : 6.0);
    EXPECT_EQ(c.away_from_sensor, 0u);
  }
}

TEST(Normals, SpanningTreeOrientsAClosedSphereConsistently) {
  SimulatedCloud sim = Simulate(Part::kSphere, SurroundingSensors(Part::kSphere), 16);
  for (ScanMeta& scan : sim.cloud.scans) {
    scan.camera_position.reset();
    scan.projector_direction.reset();
  }
  auto report = testing::RunNormalsFunction(sim.cloud);
  ASSERT_TRUE(report.ok()) << report.status();
  size_t outward = 0, valid = 0;
  for (size_t i = 0; i < sim.cloud.size(); ++i) {
    if (sim.cloud.flags[i] & kNormalInvalid) continue;
    ++valid;
    outward += sim.cloud.normal(i).dot(sim.true_normal[i]) > 0;
  }
  const double agree = static_cast<double>(std::max(outward, valid - outward)) / valid;
  std::printf(
      "closed sphere, 6 scans, no poses: %zu normals, %.4f agree with the majority "
      "(%zu outward), bridges %.0f\n",
      valid, agree, outward, report->stages.back().parameters.at("normals.tree_bridges"));
  EXPECT_GE(agree, 0.995);
  // The seed (highest point) is oriented n_z >= 0, which is outward on a sphere.
  EXPECT_GT(outward, valid / 2);
  EXPECT_EQ(report->stages.back().parameters.at("normals.oriented_by_tree"),
            static_cast<double>(valid));
  EXPECT_FALSE(report->warnings.empty());
}

TEST(Normals, CollinearAndTinyNeighbourhoodsAreInvalid) {
  PointCloud cloud;
  cloud.scans.push_back(ScanMeta{.id = "line", .camera_position = Eigen::Vector3d(0, 0, 100)});
  for (int i = 0; i < 50; ++i) {
    cloud.x.push_back(i * 0.1f);
    cloud.y.push_back(0);
    cloud.z.push_back(0);
  }
  cloud.FinishLoading();
  ASSERT_TRUE(testing::RunNormalsFunction(cloud).ok());
  for (size_t i = 0; i < cloud.size(); ++i) EXPECT_TRUE(cloud.flags[i] & kNormalInvalid);
}

// A real Cyberware range scan has no pose in its file. In each scan's own frame the scanner sits
// on +z (the range grid is a height field over x, y; the bunny's front faces +z in bun000), so
// every visible surface faces +z. Orientation here comes from the spanning tree alone.
TEST(Normals, StanfordBunnyScanFacesTheScanner) {
  SCANPREP_REQUIRE_SHARED_DATA(dir);
  std::vector<std::string> ply_warnings;
  auto cloud = io::ReadPly(dir / "stanford_bunny_range_scans" / "bun000.ply", ply_warnings);
  ASSERT_TRUE(cloud.ok()) << cloud.status();
  for (float* v : {cloud->x.data(), cloud->y.data(), cloud->z.data()}) {
    for (size_t i = 0; i < cloud->size(); ++i) v[i] *= 1000.f;  // metres → mm
  }
  auto report = testing::RunNormalsFunction(*cloud);
  ASSERT_TRUE(report.ok()) << report.status();
  size_t valid = 0, facing = 0;
  for (size_t i = 0; i < cloud->size(); ++i) {
    if (cloud->flags[i] & kNormalInvalid) continue;
    ++valid;
    facing += cloud->nz[i] > 0;
  }
  std::printf("bun000: %zu points, %zu valid normals, %.4f face +z, median radius %.3f mm\n",
              cloud->size(), valid, double(facing) / valid,
              report->stages.back().parameters.at("normals.median_radius_mm"));
  EXPECT_GE(facing, 0.95 * valid);
  EXPECT_GE(valid, 0.99 * cloud->size());
}

}  // namespace
// A 90° edge, noiseless: the top face z = 0 (x <= 0) and the side face x = 0 (z < 0) on a
// 0.1 mm grid. The Gaussian weights of Eq. (4) (h = r_p/2) are what keep the far side of the
// ball, across the edge, from tilting the normal of a point near it: on a face point between
// 0.15 and 0.35 mm from the edge the true normal is known exactly.
TEST(Normals, GaussianWeightsKeepNormalsNearAnEdgeOnTheirFace) {
  PointCloud cloud;
  cloud.scans.push_back(
      ScanMeta{.id = "edge", .camera_position = Eigen::Vector3d(100, 0, 100), .uncertainty = 0.01});
  cloud.kind = ScannerKind::kFlexible;
  constexpr float kStep = 0.1f;
  constexpr int kRows = 60, kCols = 40;
  std::vector<Eigen::Vector3f> truth;
  std::vector<float> edge_distance;
  for (int row = 0; row < kRows; ++row) {
    for (int c = 0; c < 2 * kCols; ++c) {
      const bool top = c < kCols;  // top: x = -c·step; side: z = -(c − kCols + 1)·step
      const float along = top ? c * kStep : (c - kCols + 1) * kStep;
      cloud.x.push_back(top ? -along : 0.f);
      cloud.y.push_back(row * kStep);
      cloud.z.push_back(top ? 0.f : -along);
      truth.push_back(top ? Eigen::Vector3f(0, 0, 1) : Eigen::Vector3f(1, 0, 0));
      edge_distance.push_back(along);
    }
  }
  cloud.FinishLoading();
  auto report = testing::RunNormalsFunction(cloud);
  ASSERT_TRUE(report.ok()) << report.status();
  const double r = report->stages.back().parameters.at("normals.median_radius_mm");
  std::vector<std::vector<double>> bands(6);
  for (size_t i = 0; i < cloud.size(); ++i) {
    const float y = cloud.y[i];
    if (y < 1.0f || y > (kRows - 1) * kStep - 1.0f) continue;  // away from the grid's ends
    const size_t band = static_cast<size_t>(edge_distance[i] / 0.1f + 0.5f);
    if (band < bands.size()) bands[band].push_back(AxisAngleDeg(cloud, i, truth[i]));
  }
  for (size_t b = 0; b < bands.size(); ++b) {
    std::printf("edge distance %.1f mm (r_p %.3f): median %.2f°\n", b * 0.1, r,
                Quantile(bands[b], 0.5));
  }
  // Measured: 13.9° and 2.1° with h = r_p/2; 16.3° and 3.0° with h = r_p, worse without weights.
  EXPECT_LT(Quantile(bands[1], 0.5), 15.0);
  EXPECT_LT(Quantile(bands[2], 0.5), 2.5);
  EXPECT_LT(Quantile(bands[3], 0.5), 0.1);
}

}  // namespace scanprep::testing
