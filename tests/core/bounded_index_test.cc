// SPDX-License-Identifier: Apache-2.0
// The spatial index's work per query is bounded on any distribution: on drawn hostile clouds
// (far parts in random directions, near-identical clusters, lines; tests/support/hostile_mix.h)
// every k-NN query and every capped ball reads at most the grid's budget plus a small multiple
// of what it returns, counted (candidates_examined_by_this_thread), not timed. The control: the
// same balls hold far more points than that bound, so only the index's mechanism keeps it. And
// the kd-tree the grid falls back on answers exactly what the reference kd-tree answers.
#include <algorithm>
#include <cstdio>
#include <random>

#include <gtest/gtest.h>

#include "core/spatial/duplicates.h"
#include "core/spatial/neighbourhoods.h"
#include "tests/support/hostile_mix.h"
#include "tests/support/kdtree.h"

namespace scanprep {
namespace {

constexpr uint32_t kK = 20;
// The most a query that wants `wanted` points may read: the grid's budget (CellGrid::GridBudget,
// restated here so that a change to it shows as a change to this test) and, where the kd-tree
// answers instead, 16 leaves of 16 for its descent and 32 reads per point it returns (measured:
// up to 25 a point for k = 20 in a cluster whose points sit on a few float values a side, where
// many lie at nearly the same distance; about 2 on a surface).
size_t MostReads(size_t wanted) { return std::max<size_t>(2048, 2 * wanted) + 256 + 32 * wanted; }

// The cloud as the pipeline indexes it: exact duplicates collapsed (duplicates.h).
PointCloud Collapsed(const PointCloud& cloud) {
  absl::StatusOr<DuplicateGroups> groups = FindDuplicates(cloud, CancelToken());
  EXPECT_TRUE(groups.ok());
  return CompactDuplicates(cloud, *groups);
}

uint64_t SeedFromEnvironment() {
  const char* seed = std::getenv("SCANPREP_HOSTILE_SEED");
  return seed != nullptr ? std::strtoull(seed, nullptr, 10) : std::random_device()();
}

TEST(BoundedIndex, EveryQueryOnDrawnHostileCloudsReadsABoundedNumberOfCandidates) {
  const uint64_t seed = SeedFromEnvironment();
  std::printf("hostile mix seed %llu (SCANPREP_HOSTILE_SEED=%llu repeats it)\n",
              static_cast<unsigned long long>(seed), static_cast<unsigned long long>(seed));
  size_t trees = 0, read_in_part = 0;
  for (uint64_t draw = 0; draw < 12; ++draw) {
    // The first two draws hold a far part and clusters for sure: the controls below need them.
    const testing::HostileMix mix =
        testing::DrawHostileMix(100'000, seed + draw, {.far = draw == 0, .clusters = draw == 1});
    SCOPED_TRACE(mix.description + "seed " + std::to_string(seed + draw));
    const PointCloud cloud = Collapsed(mix.cloud);
    CancelToken cancel;
    auto nb = Neighbourhoods::Build(cloud, {.k = kK}, cancel);
    ASSERT_TRUE(nb.ok()) << nb.status();
    const CellGrid& grid = (*nb)->grid();
    const float ball_radius = 5 * static_cast<float>((*nb)->global_radius());
    std::vector<uint32_t> idx(kK);
    std::vector<float> d2(kK);
    std::vector<uint64_t> scratch;
    RadiusMatches ball;
    const size_t cap = (*nb)->max_ball_points();
    for (size_t i = 0; i < cloud.size(); i += 17) {
      const float q[3] = {cloud.x[i], cloud.y[i], cloud.z[i]};
      uint64_t before = candidates_examined_by_this_thread;
      grid.Knn(q, kK, static_cast<uint32_t>(i), 0.f, idx.data(), d2.data(), scratch);
      ASSERT_LE(candidates_examined_by_this_thread - before, MostReads(kK)) << "k-NN of " << i;
      before = candidates_examined_by_this_thread;
      grid.Ball(q, {.limit_sq = ball_radius * ball_radius, .count = cap}, ball_radius, ball);
      const uint64_t read = candidates_examined_by_this_thread - before;
      ASSERT_LE(read, MostReads(cap)) << "ball of " << i;
      // The control: how many points the ball really holds (uncapped, so a cluster's ball may
      // be read whole); a ball holding four times what it read was answered without that.
      if (i % (17 * 20) == 0) {
        grid.Within(q, ball_radius, ball);  // uncapped: every point of the ball
        read_in_part += ball.size() > 4 * read;
      }
    }
    trees += grid.tree_built();
  }
  // The draws included clouds the grid alone could not bound (the tree was needed), and balls
  // holding four times what their capped query read: a grid reading every candidate in the
  // ball's cells would have read all of them.
  EXPECT_GT(trees, 0u);
  EXPECT_GT(read_in_part, 0u);
}

// Forced onto the kd-tree (a far part stretches the cells until the sheet shares a few), the
// grid's answers equal the reference kd-tree's: every k-NN list's distances, every ball's set,
// and a capped ball's `count` smallest distances.
TEST(BoundedIndex, TheFallbackTreeAnswersExactly) {
  const testing::HostileMix mix =
      testing::DrawHostileMix(20'000, SeedFromEnvironment(), {.far = true, .clusters = true});
  SCOPED_TRACE(mix.description);
  const PointCloud cloud = Collapsed(mix.cloud);
  CancelToken cancel;
  CellGrid grid;
  ASSERT_TRUE(grid.Build(cloud, 0.f, cancel).ok());
  KdTree tree(cloud);
  std::vector<uint32_t> tree_idx(kK + 1), grid_idx(kK);
  std::vector<float> tree_d2(kK + 1), grid_d2(kK);
  std::vector<uint64_t> scratch;
  RadiusMatches expected, got;
  for (size_t i = 0; i < cloud.size(); i += 7) {
    const float q[3] = {cloud.x[i], cloud.y[i], cloud.z[i]};
    ASSERT_EQ(tree.Knn(q, kK + 1, tree_idx.data(), tree_d2.data()), kK + 1);
    ASSERT_EQ(
        grid.Knn(q, kK, static_cast<uint32_t>(i), 0.f, grid_idx.data(), grid_d2.data(), scratch),
        kK);
    for (size_t m = 0; m < kK; ++m) ASSERT_EQ(grid_d2[m], tree_d2[m + 1]) << i << " rank " << m;
    for (float radius : {0.05f, 0.5f, 3.f}) {
      tree.Radius(q, radius, expected);
      grid.Within(q, radius, got);
      std::sort(expected.begin(), expected.end());
      std::sort(got.begin(), got.end());
      ASSERT_EQ(got, expected) << "point " << i << " radius " << radius;
      // Capped at 10: the reference's 10 smallest distances (which of the points tied at the
      // tenth is kept is the tree's choice, as in nanoflann's k-NN).
      std::vector<float> nearest, kept;
      for (const auto& m : expected) nearest.push_back(m.second);
      std::sort(nearest.begin(), nearest.end());
      const bool fuller = nearest.size() > 10;
      if (fuller) nearest.resize(10);
      const size_t left_out = grid.Ball(q, {.limit_sq = radius * radius, .count = 10}, radius, got);
      for (const auto& m : got) kept.push_back(m.second);
      std::sort(kept.begin(), kept.end());
      ASSERT_EQ(kept, nearest) << "capped ball of " << i << " radius " << radius;
      ASSERT_EQ(left_out > 0, fuller) << "capped ball of " << i << " radius " << radius;
    }
  }
  EXPECT_TRUE(grid.tree_built());  // the control: these answers came from the tree
}

}  // namespace
}  // namespace scanprep
