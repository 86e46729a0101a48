// SPDX-License-Identifier: Apache-2.0
// The grid must answer exactly what the kd-tree answers: every ball the same set of points with
// the same squared distances, every k-NN list the same distances. Checked on a simulated scan
// pair, on a cloud with far-flung points (wide bounding box, few occupied cells) and on one with
// coincident points, and again after points moved.
#include "core/spatial/cell_grid.h"

#include <algorithm>
#include <random>

#include <gtest/gtest.h>

#include "core/sim/scan_simulator.h"
#include "core/spatial/neighbourhoods.h"
#include "tests/support/kdtree.h"
#include "tests/support/planned_stages.h"
#include "tests/support/random_clouds.h"

namespace scanprep {
namespace {

PointCloud BoxScans() {
  const auto part = sim::Part::kBoxWithBore;
  return sim::SimulateWithPointCount(part, sim::TwoOverlappingSensors(part), 40'000, 0.01, 3).cloud;
}

// A plane of 0.1 mm pitch, a few points a metre away, and clusters of exact duplicates.
PointCloud SparseAndDuplicated() {
  PointCloud cloud;
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> jitter(-0.02f, 0.02f);
  for (int r = 0; r < 120; ++r) {
    for (int c = 0; c < 120; ++c) {
      cloud.x.push_back(c * 0.1f + jitter(rng));
      cloud.y.push_back(r * 0.1f + jitter(rng));
      cloud.z.push_back(jitter(rng));
    }
  }
  for (int far = 0; far < 5; ++far) {
    cloud.x.push_back(1000.f * far - 2000.f);
    cloud.y.push_back(-700.f * far);
    cloud.z.push_back(300.f + far);
  }
  for (int dup = 0; dup < 30; ++dup) {
    cloud.x.push_back(5.f);
    cloud.y.push_back(5.f);
    cloud.z.push_back(0.5f);
  }
  cloud.FinishLoading();
  return cloud;
}

// Compares grid and tree balls of several radii around every 7th point and a few off-cloud
// points.
void ExpectSameBalls(const PointCloud& cloud, const CellGrid& grid) {
  KdTree tree(cloud);
  RadiusMatches expected;
  RadiusMatches got;
  size_t compared = 0, found = 0;
  for (size_t i = 0; i < cloud.size(); i += 7) {
    for (float radius : {0.03f, 0.09f, 0.25f, 0.6f}) {
      const float q[3] = {cloud.x[i] + 0.01f * (i % 3), cloud.y[i], cloud.z[i] - 0.005f * (i % 5)};
      tree.Radius(q, radius, expected);
      grid.Within(q, radius, got);
      std::sort(expected.begin(), expected.end());
      std::sort(got.begin(), got.end());
      ASSERT_EQ(got, expected) << "point " << i << " radius " << radius;
      ++compared;
      found += got.size();
    }
  }
  EXPECT_GT(found, compared);  // the balls were not all empty
}

void ExpectSameKnn(const PointCloud& cloud, const CellGrid& grid, size_t k) {
  KdTree tree(cloud);
  std::vector<uint32_t> tree_idx(k + 1), grid_idx(k);
  std::vector<float> tree_d2(k + 1), grid_d2(k);
  std::vector<uint64_t> scratch;
  for (size_t i = 0; i < cloud.size(); i += 5) {
    const float q[3] = {cloud.x[i], cloud.y[i], cloud.z[i]};
    const size_t expected = tree.Knn(q, k + 1, tree_idx.data(), tree_d2.data());
    const size_t got =
        grid.Knn(q, k, static_cast<uint32_t>(i), 0.f, grid_idx.data(), grid_d2.data(), scratch);
    ASSERT_EQ(got, std::min(k, cloud.size() - 1));
    ASSERT_EQ(expected, got + 1);
    // The tree's list holds i itself at distance 0; duplicates of i too, so drop one zero.
    tree_d2.erase(tree_d2.begin());
    for (size_t m = 0; m < got; ++m) {
      ASSERT_EQ(grid_d2[m], tree_d2[m]) << "point " << i << " rank " << m;
      if (m > 0) {
        ASSERT_LE(grid_d2[m - 1], grid_d2[m]);
      }
      ASSERT_NE(grid_idx[m], i);
    }
    tree_d2.resize(k + 1);
  }
}

TEST(CellGrid, BallsAndNeighboursEqualTheKdTreesOnScans) {
  const PointCloud cloud = BoxScans();
  CancelToken cancel;
  for (float edge : {0.f, 0.02f, 0.07f, 0.5f}) {
    CellGrid grid;
    ASSERT_TRUE(grid.Build(cloud, edge, cancel).ok());
    ExpectSameBalls(cloud, grid);
    ExpectSameKnn(cloud, grid, 20);
  }
}

TEST(CellGrid, BallsAndNeighboursEqualTheKdTreesOnSparseAndDuplicatedPoints) {
  const PointCloud cloud = SparseAndDuplicated();
  CancelToken cancel;
  for (float edge : {0.f, 0.1f}) {
    CellGrid grid;
    ASSERT_TRUE(grid.Build(cloud, edge, cancel).ok());
    ExpectSameBalls(cloud, grid);
    ExpectSameKnn(cloud, grid, 20);
    ExpectSameKnn(cloud, grid, 40);
  }
}

// A tall thin column of points: 2^21 cells along z and tens of thousands of columns need sort
// keys wider than 32 bits, the other sort; the scans' grids (the control) use 32-bit keys.
TEST(CellGrid, BallsAndNeighboursEqualTheKdTreesWithWideSortKeys) {
  const PointCloud tall =
      testing::UniformBoxCloud(20'000, {0.f, 0.f, 0.f}, {1.f, 1.f, 10'000.f}, 5);
  CancelToken cancel;
  CellGrid grid;
  ASSERT_TRUE(grid.Build(tall, 0.001f, cancel).ok());  // widened to 10 m / 2^21
  EXPECT_GT(grid.key_bits(), 32);
  ExpectSameBalls(tall, grid);
  ExpectSameKnn(tall, grid, 20);

  CellGrid control;
  ASSERT_TRUE(control.Build(BoxScans(), 0.f, cancel).ok());
  EXPECT_LE(control.key_bits(), 32);
}

TEST(CellGrid, OrderVisitsEveryPointOnce) {
  const PointCloud cloud = BoxScans();
  CellGrid grid;
  ASSERT_TRUE(grid.Build(cloud, 0.f, CancelToken()).ok());
  std::vector<uint32_t> order(grid.order().begin(), grid.order().end());
  std::sort(order.begin(), order.end());
  for (uint32_t i = 0; i < order.size(); ++i) ASSERT_EQ(order[i], i);
  EXPECT_EQ(order.size(), cloud.size());
}

// The compact graph decodes to the k nearest (the kd-tree's distances, nearest first), and again
// once the points moved and the lists were re-ranked. A tall narrow plane puts its two grid
// columns 50,000 ranks apart, so lists across them need 32-bit indices; the scans' lists (the
// control) all fit 16-bit differences.
void ExpectNearestLists(const PointCloud& cloud, const Neighbourhoods& nb) {
  KdTree tree(cloud);
  const uint32_t k = nb.k();
  std::vector<uint32_t> idx(k + 1);
  std::vector<float> d2(k + 1);
  for (size_t i = 0; i < cloud.size(); i += 3) {
    const float q[3] = {cloud.x[i], cloud.y[i], cloud.z[i]};
    ASSERT_EQ(tree.Knn(q, k + 1, idx.data(), d2.data()), k + 1);
    const KnnList list = nb.knn(i);
    ASSERT_EQ(list.size(), k);
    for (uint32_t m = 0; m < k; ++m) {
      ASSERT_NE(list[m], i);
      ASSERT_EQ(cloud.squared_distance(i, list[m]), d2[m + 1]) << "point " << i << " rank " << m;
      ASSERT_EQ(list.dist(cloud, m), std::sqrt(d2[m + 1]));
      ASSERT_EQ(nb.knn_dist(cloud, i, m), list.dist(cloud, m));
    }
  }
}

TEST(Neighbourhoods, CompactGraphHoldsTheNearest) {
  PointCloud plane;
  std::mt19937 rng(9);
  std::uniform_real_distribution<float> jitter(-0.1f, 0.1f);
  for (int z = 0; z < 10'000; ++z) {
    for (int y = 0; y < 10; ++y) {
      plane.x.push_back(jitter(rng));
      plane.y.push_back(y + jitter(rng));
      plane.z.push_back(z + jitter(rng));
    }
  }
  plane.FinishLoading();
  PointCloud scans = BoxScans();
  CancelToken cancel;
  for (PointCloud* cloud : {&plane, &scans}) {
    auto nb = Neighbourhoods::Build(*cloud, {.k = 20}, cancel);
    ASSERT_TRUE(nb.ok());
    if (cloud == &plane) {
      EXPECT_GT((*nb)->wide_lists(), 1000u);
    } else {
      EXPECT_EQ((*nb)->wide_lists(), 0u);
    }
    ExpectNearestLists(*cloud, **nb);
    // Moved: every list keeps its points, re-ranked by their new distances.
    auto members = [&](size_t i) {
      const KnnList list = (*nb)->knn(i);
      std::vector<uint32_t> ids(list.begin(), list.end());
      std::sort(ids.begin(), ids.end());
      return ids;
    };
    std::vector<std::vector<uint32_t>> before;
    for (size_t i = 0; i < cloud->size(); i += 3) before.push_back(members(i));
    std::uniform_real_distribution<float> move(-0.2f, 0.2f);
    for (size_t i = 0; i < cloud->size(); ++i) cloud->x[i] += move(rng);
    ASSERT_TRUE((*nb)->PointsMoved(*cloud, 0.2f, cancel).ok());
    for (size_t i = 0; i < cloud->size(); i += 3) {
      ASSERT_EQ(members(i), before[i / 3]) << "point " << i;
      const KnnList list = (*nb)->knn(i);
      for (uint32_t m = 1; m < list.size(); ++m) {
        ASSERT_LE(cloud->squared_distance(i, list[m - 1]), cloud->squared_distance(i, list[m]));
      }
    }
  }
}

TEST(Neighbourhoods, WithinStaysExactAfterPointsMove) {
  PointCloud cloud = BoxScans();
  CancelToken cancel;
  auto nb = Neighbourhoods::Build(cloud, {.k = 20}, cancel);
  ASSERT_TRUE(nb.ok());
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> move(-0.03f, 0.03f);
  for (size_t i = 0; i < cloud.size(); ++i) {
    cloud.x[i] += move(rng);
    cloud.y[i] += move(rng);
    cloud.z[i] += move(rng);
  }
  ASSERT_TRUE((*nb)->PointsMoved(cloud, 0.03f * std::sqrt(3.f), cancel).ok());
  ExpectSameBalls(cloud, (*nb)->grid());
  KdTree tree(cloud);
  RadiusMatches expected, got;
  for (size_t i = 0; i < cloud.size(); i += 11) {
    const float q[3] = {cloud.x[i], cloud.y[i], cloud.z[i]};
    const float radius = (*nb)->dk(i) * 0.8f;  // inside the k-NN list, which may now be stale
    tree.Radius(q, radius, expected);
    (*nb)->Within(cloud, i, radius, got);
    std::sort(expected.begin(), expected.end());
    std::sort(got.begin(), got.end());
    ASSERT_EQ(got, expected) << "point " << i;
  }
}

// A ball for a fit on a densely sampled plane (0.01 mm pitch, radius 0.1 mm: about 310 points,
// twice as many candidates): Sample reads a lattice of 2·sample_points() of its cells' entries
// and returns those inside, an even spread of the ball with its centre first. Each
// quadrant around the centre holds its quarter and the mean distance its share (2r/3 on a disc),
// so a plane fit or a mean over it sees the ball, not a corner of it. The control: the whole
// ball (Within) holds more points than the sample reads.
TEST(Neighbourhoods, SampledBallIsAnEvenSubsetWithItsCentreFirst) {
  PointCloud cloud;
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> jitter(-0.002f, 0.002f);
  for (int r = 0; r < 120; ++r) {
    for (int c = 0; c < 120; ++c) {
      cloud.x.push_back(c * 0.01f + jitter(rng));
      cloud.y.push_back(r * 0.01f + jitter(rng));
      cloud.z.push_back(jitter(rng));
    }
  }
  cloud.FinishLoading();
  auto nb = Neighbourhoods::Build(cloud, {.k = 20}, CancelToken());
  ASSERT_TRUE(nb.ok());
  const float radius = 0.1f;
  RadiusMatches whole, sample;
  for (const size_t i : {size_t{60 * 120 + 60}, size_t{45 * 120 + 70}, size_t{70 * 120 + 41}}) {
    (*nb)->Within(cloud, i, radius, whole);
    const uint64_t sampled_before = (*nb)->sampled_balls();
    EXPECT_TRUE((*nb)->Sample(cloud, i, radius, sample));
    EXPECT_EQ((*nb)->sampled_balls(), sampled_before + 1);
    ASSERT_GT(whole.size(), 2 * (*nb)->sample_points()) << "the control: a ball worth sampling";
    ASSERT_FALSE(sample.empty());
    EXPECT_EQ(sample.front(), std::make_pair(static_cast<uint32_t>(i), 0.f));
    EXPECT_LE(sample.size(), 2 * (*nb)->sample_points());
    EXPECT_GE(sample.size(), (*nb)->sample_points() / 2);
    std::sort(whole.begin(), whole.end());
    int quadrant[4] = {0, 0, 0, 0};
    double mean_distance = 0;
    for (const auto& m : sample) {
      EXPECT_TRUE(std::binary_search(whole.begin(), whole.end(), m)) << "point " << m.first;
      const float dx = cloud.x[m.first] - cloud.x[i], dy = cloud.y[m.first] - cloud.y[i];
      ++quadrant[(dx > 0) + 2 * (dy > 0)];
      mean_distance += std::sqrt(m.second) / double(sample.size());
    }
    std::sort(sample.begin(), sample.end());
    EXPECT_EQ(std::adjacent_find(sample.begin(), sample.end()), sample.end());
    for (const int q : quadrant) {
      EXPECT_NEAR(q, sample.size() / 4.0, sample.size() * 0.08) << "centre " << i;
    }
    EXPECT_NEAR(mean_distance, 2 * radius / 3, 0.1 * radius) << "centre " << i;
  }
  // A ball whose cells hold no more than the sample reads is read whole.
  const size_t centre = 60 * 120 + 60;
  (*nb)->Within(cloud, centre, 0.03f, whole);
  (*nb)->Sample(cloud, centre, 0.03f, sample);
  std::sort(whole.begin(), whole.end());
  std::sort(sample.begin(), sample.end());
  EXPECT_EQ(sample, whole);
}

// A job mixing a fine line sensor (Δs = 0.1 mm) and a coarse one (Δs = 1 mm) side by side: each
// scan's r_min follows Eq. (2) from its own spacing and uncertainty, r_min = √3·Δs + u, so the
// fine sensor's balls are not blown up to the coarse one's.
TEST(Neighbourhoods, MinimumRadiusIsPerScan) {
  PointCloud cloud;
  cloud.kind = ScannerKind::kLine;
  cloud.scans = {ScanMeta{.id = "fine", .scanline_spacing = 0.1, .uncertainty = 0.1},
                 ScanMeta{.id = "coarse", .scanline_spacing = 1.0, .uncertainty = 0.6}};
  for (uint32_t s = 0; s < 2; ++s) {
    const float step = s == 0 ? 0.1f : 1.f;
    for (int row = 0; row < 60; ++row) {
      for (int col = 0; col < 60; ++col) {
        cloud.x.push_back(col * step + (s == 0 ? 0.f : 100.f));
        cloud.y.push_back(row * step);
        cloud.z.push_back(0);
        cloud.scan.push_back(s);
        cloud.scanline.push_back(row);
      }
    }
  }
  cloud.FinishLoading();
  testing::PlannedStages job(cloud, {"neighbourhoods"});
  ASSERT_TRUE(job.Run().ok());
  const auto& p = job.report().stages.back().parameters;
  EXPECT_NEAR(p.at("neighbourhoods.min_radius_mm.scan0"), std::sqrt(3.0) * 0.1 + 0.1, 1e-9);
  EXPECT_NEAR(p.at("neighbourhoods.min_radius_mm.scan1"), std::sqrt(3.0) * 1.0 + 0.6, 1e-9);
  EXPECT_NEAR(p.at("neighbourhoods.epsilon_u_mm.scan1"), 0.6, 1e-12);
  const Neighbourhoods& nb = job.neighbourhoods();
  // Mid-grid points: d_k (k = 20 on a square grid: √5·step) is below r_min for both.
  const size_t fine = 30 * 60 + 30, coarse = 3600 + 30 * 60 + 30;
  EXPECT_NEAR(nb.adaptive_radius(fine), std::sqrt(3.0) * 0.1 + 0.1, 1e-6);
  EXPECT_NEAR(nb.adaptive_radius(coarse), std::sqrt(3.0) * 1.0 + 0.6, 1e-6);
}

}  // namespace
}  // namespace scanprep
