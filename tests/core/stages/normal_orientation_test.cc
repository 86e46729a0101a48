// SPDX-License-Identifier: Apache-2.0
// Orientation without a sensor pose (docs/algorithms.md §7) on a cluttered table-top scene like
// PCL's rs1.pcd: a table plane and dozens of separate objects, so the k-NN graph falls apart into
// many components that the spanning tree has to bridge. The bridging must stay O(n) work
// (the earlier widening search was quadratic here) and every surface must come out consistent.
#include <cmath>
#include <cstdio>
#include <random>
#include <string>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "tests/support/normals_call.h"

namespace scanprep {
namespace {

struct Scene {
  PointCloud cloud;
  std::vector<Eigen::Vector3f> true_normal;  // outward (objects) or up (table)
  std::vector<uint32_t> object;              // 0 = table, 1.. = objects
  uint32_t objects = 0;
};

void Add(Scene& scene, const Eigen::Vector3f& p, const Eigen::Vector3f& normal, uint32_t object,
         std::mt19937& rng) {
  std::normal_distribution<float> noise(0.f, 0.02f);
  const Eigen::Vector3f q = p + noise(rng) * normal;
  scene.cloud.x.push_back(q.x());
  scene.cloud.y.push_back(q.y());
  scene.cloud.z.push_back(q.z());
  scene.true_normal.push_back(normal);
  scene.object.push_back(object);
}

// A 280 × 230 mm table at z = 0 and 6 × 5 objects hovering 4 mm above it (so each is its own
// k-NN component, as clutter on rs1's table is): spheres of radius 6-15 mm and boxes of edge
// 12-30 mm, alternating. Points are uniformly random on the surfaces, 0.8 per mm² (spacing
// ≈ 1.1 mm), no scanlines and no sensor pose.
Scene TableTop(uint64_t seed) {
  Scene scene;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> unit(0.f, 1.f);
  const float density = 0.8f;  // points per mm²
  for (int i = 0; i < static_cast<int>(280 * 230 * density); ++i) {
    Add(scene, {280 * unit(rng) - 140, 230 * unit(rng) - 115, 0}, {0, 0, 1}, 0, rng);
  }
  for (int gx = 0; gx < 6; ++gx) {
    for (int gy = 0; gy < 5; ++gy) {
      const uint32_t id = ++scene.objects;
      const float size = 6 + 9 * ((gx * 5 + gy) % 7) / 6.f;  // 6..15 mm
      const Eigen::Vector3f centre(-125 + 50 * gx, -100 + 50 * gy, 4 + size);
      if ((gx + gy) % 2 == 0) {
        std::normal_distribution<float> gauss;
        const int count = static_cast<int>(4 * M_PI * size * size * density);
        for (int i = 0; i < count; ++i) {
          const Eigen::Vector3f d =
              Eigen::Vector3f(gauss(rng), gauss(rng), gauss(rng)).normalized();
          Add(scene, centre + size * d, d, id, rng);
        }
      } else {
        // A cube of half-edge `size`: each face sampled uniformly.
        const int per_face = static_cast<int>(4 * size * size * density);
        for (int axis = 0; axis < 3; ++axis) {
          for (float sign : {-1.f, 1.f}) {
            Eigen::Vector3f normal = Eigen::Vector3f::Zero();
            normal[axis] = sign;
            for (int i = 0; i < per_face; ++i) {
              Eigen::Vector3f p;
              p[axis] = sign * size;
              p[(axis + 1) % 3] = size * (2 * unit(rng) - 1);
              p[(axis + 2) % 3] = size * (2 * unit(rng) - 1);
              Add(scene, centre + p, normal, id, rng);
            }
          }
        }
      }
    }
  }
  scene.cloud.scans.push_back(ScanMeta{.id = "table", .uncertainty = 0.06});
  scene.cloud.FinishLoading();
  return scene;
}

// Without a pose the sign of each separate surface is a free choice (the bridge between two
// objects that do not touch carries no information about their relative sign), so what is
// asserted is per surface: nearly all its normals agree with the true normal, or nearly all with
// its opposite. Normals more than 60° off the true axis (blended PCA at box edges) say nothing
// about the sign and are left out. The highest point's object is the seed's, set n_z >= 0: there
// the sign is asserted too (outward).
TEST(NormalOrientation, ClutteredTableWithoutPoseIsConsistentInLinearWork) {
  Scene scene = TableTop(7);
  PointCloud& cloud = scene.cloud;
  const size_t n = cloud.size();
  auto report = testing::RunNormalsFunction(cloud);
  ASSERT_TRUE(report.ok()) << report.status();
  const auto& parameters = report->stages.back().parameters;
  const double bridges = parameters.at("normals.tree_bridges");
  const double work = parameters.at("normals.bridge_work");
  std::printf(
      "table-top: %zu points, %u objects, %.0f bridges, bridge work %.0f (%.3f per "
      "point)\n",
      n, scene.objects, bridges, work, work / n);
  // One component per object and the table, so at least that many bridges minus one.
  EXPECT_GE(bridges, scene.objects);
  // The bound of normal_orientation.cc: per component 64 samples asking 129 neighbours each,
  // and the bridges at most 5·n: 31·64·129 + 5·n, under 8 per point here. The
  // earlier widening search asked for 4.6·10⁶ (45 per point), and more the larger the
  // components: each round queried every point outside the largest one.
  EXPECT_LE(work, (scene.objects + 1) * 64 * 129 + 5 * n);

  std::vector<size_t> agree(scene.objects + 1, 0), checked(scene.objects + 1, 0);
  size_t seed = 0;
  for (size_t i = 0; i < n; ++i) {
    if (cloud.z[i] > cloud.z[seed]) seed = i;
    if (cloud.flags[i] & kNormalInvalid) continue;
    const float c = cloud.normal(i).dot(scene.true_normal[i]);
    if (std::abs(c) < 0.5f) continue;
    ++checked[scene.object[i]];
    agree[scene.object[i]] += c > 0;
  }
  for (uint32_t o = 0; o <= scene.objects; ++o) {
    ASSERT_GT(checked[o], 100u) << "object " << o;
    const double majority = std::max(agree[o], checked[o] - agree[o]) / double(checked[o]);
    EXPECT_GE(majority, 0.99) << "object " << o << ": " << agree[o] << " of " << checked[o]
                              << " outward";
  }
  const uint32_t top = scene.object[seed];
  EXPECT_GE(agree[top], 0.99 * checked[top]) << "the seed's object " << top;
}

// Thousands of components: 2,940 patches of 4 × 4 points, 0.1 mm apart, each tilted its own way,
// on a lattice 3 mm apart, so none reaches another in the 10-NN orientation graph. All must be
// joined into one tree, with work linear in the points: each point is a sample asking for
// 16 + 64 + 1 neighbours, and the bridges ask at most 5 per point.
TEST(NormalOrientation, ThousandsOfSmallComponentsAreJoinedInLinearWork) {
  PointCloud cloud;
  std::mt19937 rng(3);
  std::normal_distribution<float> gauss;
  size_t patches = 0;
  for (int a = 0; a < 14; ++a) {
    for (int b = 0; b < 14; ++b) {
      for (int c = 0; c < 15; ++c, ++patches) {
        const Eigen::Vector3f normal =
            Eigen::Vector3f(gauss(rng), gauss(rng), gauss(rng)).normalized();
        const Eigen::Vector3f u = normal.unitOrthogonal(), v = normal.cross(u);
        for (int s = 0; s < 4; ++s) {
          for (int t = 0; t < 4; ++t) {
            const Eigen::Vector3f p =
                Eigen::Vector3f(3 * a, 3 * b, 3 * c) + 0.1f * s * u + 0.1f * t * v;
            cloud.x.push_back(p.x());
            cloud.y.push_back(p.y());
            cloud.z.push_back(p.z());
          }
        }
      }
    }
  }
  cloud.scans.push_back(ScanMeta{.id = "patches", .uncertainty = 0.01});
  cloud.FinishLoading();
  const size_t n = cloud.size();
  auto report = testing::RunNormalsFunction(cloud);
  ASSERT_TRUE(report.ok()) << report.status();
  const auto& parameters = report->stages.back().parameters;
  const double work = parameters.at("normals.bridge_work");
  const double valid = n - parameters.at("normals.invalid");
  std::printf(
      "%zu patches, %zu points: %.0f valid normals, %.0f bridges, bridge work %.0f "
      "(%.2f per point)\n",
      patches, n, valid, parameters.at("normals.tree_bridges"), work, work / n);
  EXPECT_EQ(valid, n);
  EXPECT_EQ(parameters.at("normals.tree_bridges"), patches - 1);
  EXPECT_EQ(parameters.at("normals.oriented_by_tree"), valid);
  EXPECT_LE(work, (16 + 64 + 1 + 5) * n);
}

// One point per scan: every normal is invalid (the own scan has no neighbours), so nothing is
// propagated or bridged, and the stage still succeeds.
TEST(NormalOrientation, AThousandOnePointScansNeedNoBridges) {
  PointCloud cloud;
  for (int s = 0; s < 1000; ++s) {
    cloud.x.push_back(0.5f * (s % 10));
    cloud.y.push_back(0.5f * (s / 10 % 10));
    cloud.z.push_back(0.5f * (s / 100));
    cloud.scan.push_back(s);
    cloud.scans.push_back(ScanMeta{.id = "s" + std::to_string(s)});
  }
  cloud.FinishLoading();
  auto report = testing::RunNormalsFunction(cloud);
  ASSERT_TRUE(report.ok()) << report.status();
  const auto& parameters = report->stages.back().parameters;
  EXPECT_EQ(parameters.at("normals.invalid"), 1000);
  EXPECT_EQ(parameters.at("normals.tree_bridges"), 0);
  EXPECT_EQ(parameters.at("normals.bridge_work"), 0);
}

}  // namespace
}  // namespace scanprep
