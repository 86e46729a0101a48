// SPDX-License-Identifier: Apache-2.0
// The spatial index's work per query is bounded on any distribution: on drawn hostile clouds
// (far parts in random directions, near-identical clusters, lines; tests/support/hostile_mix.h)
// every k-NN query and every capped ball reads at most the grid's budget plus a small multiple
// of what it returns, counted (candidates_examined_by_this_thread), not timed — but for a shared
// allowance of a few passes over the points that over-budget queries read before the grid builds
// its kd-tree (CellGrid::OverflowAllowance). The control: the
// same balls hold far more points than that bound, so only the index's mechanism keeps it. And
// the kd-tree the grid falls back on answers exactly what the reference kd-tree answers.
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <random>

#include <gtest/gtest.h>

#include "core/spatial/duplicates.h"
#include "core/spatial/entry_tree.h"
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

uint64_t Over(uint64_t read, size_t bound) { return read > bound ? read - bound : 0; }

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
    // The first draw from a fixed seed (a far part of 28 % 8·10⁵ mm away on a diagonal: the
    // grid's cells hold most of the sheet each), the second with clusters for sure: the controls
    // below need them, every run.
    const testing::HostileMix mix = testing::DrawHostileMix(
        100'000, draw == 0 ? 2 : seed + draw, {.far = draw == 0, .clusters = draw == 1});
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
    uint64_t over = 0;  // what queries read beyond their own bound, from the grid's allowance
    for (size_t i = 0; i < cloud.size(); i += 17) {
      const float q[3] = {cloud.x[i], cloud.y[i], cloud.z[i]};
      uint64_t before = candidates_examined_by_this_thread;
      grid.Knn(q, kK, static_cast<uint32_t>(i), 0.f, idx.data(), d2.data(), scratch);
      over += Over(candidates_examined_by_this_thread - before, MostReads(kK));
      before = candidates_examined_by_this_thread;
      grid.Ball(q, {.limit_sq = ball_radius * ball_radius, .count = cap}, ball_radius, ball);
      const uint64_t read = candidates_examined_by_this_thread - before;
      over += Over(read, MostReads(cap));
      // Past the allowance every query is held to its own bound.
      ASSERT_LE(over, grid.OverflowAllowance()) << "query of point " << i;
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

// The kd-tree the grid falls back on answers what the reference kd-tree answers and what the
// grid answers (tests/core/cell_grid_test.cc): every k-NN list, every ball's set, and a capped
// ball's `count` nearest, ties to the lower index — so which of the two answered a query never
// shows. On a hostile cloud (a far part and clusters), from the tree directly.
TEST(BoundedIndex, TheFallbackTreeAnswersExactly) {
  const testing::HostileMix mix =
      testing::DrawHostileMix(20'000, SeedFromEnvironment(), {.far = true, .clusters = true});
  SCOPED_TRACE(mix.description);
  const PointCloud cloud = Collapsed(mix.cloud);
  std::vector<GridEntry> entries(cloud.size());
  std::vector<uint32_t> ids(cloud.size());
  for (uint32_t i = 0; i < cloud.size(); ++i) {
    entries[i] = {cloud.x[i], cloud.y[i], cloud.z[i]};
    ids[i] = i;
  }
  CancelToken cancel;
  auto fallback = EntryTree::Build(entries, ids, cancel);
  ASSERT_TRUE(fallback.ok()) << fallback.status();
  KdTree tree(cloud);
  std::vector<uint32_t> tree_idx(kK + 1);
  std::vector<float> tree_d2(kK + 1);
  std::vector<uint64_t> keys;
  RadiusMatches expected;
  // (squared distance, index) pairs, the reference's order.
  auto by_distance = [](const auto& a, const auto& b) {
    return a.second < b.second || (a.second == b.second && a.first < b.first);
  };
  auto as_matches = [](const std::vector<uint64_t>& keys) {
    RadiusMatches out;
    for (const uint64_t key : keys) {
      out.emplace_back(static_cast<uint32_t>(key),
                       std::bit_cast<float>(static_cast<uint32_t>(key >> 32)));
    }
    return out;
  };
  for (uint32_t i = 0; i < cloud.size(); i += 7) {
    const float q[3] = {cloud.x[i], cloud.y[i], cloud.z[i]};
    // k-NN: the reference's k + 1 nearest (i itself first) without i.
    ASSERT_EQ(tree.Knn(q, kK + 1, tree_idx.data(), tree_d2.data()), kK + 1);
    (*fallback)->Nearest(q, {.limit_sq = HUGE_VALF, .count = kK, .exclude = i}, keys);
    RadiusMatches got = as_matches(keys);
    std::sort(got.begin(), got.end(), by_distance);
    ASSERT_EQ(got.size(), kK);
    for (size_t m = 0; m < kK; ++m) ASSERT_EQ(got[m].second, tree_d2[m + 1]) << i << " rank " << m;
    for (float radius : {0.05f, 0.5f, 3.f}) {
      tree.Radius(q, radius, expected);
      std::sort(expected.begin(), expected.end(), by_distance);
      (*fallback)->Nearest(q, {.limit_sq = radius * radius, .count = SIZE_MAX}, keys);
      got = as_matches(keys);
      std::sort(got.begin(), got.end(), by_distance);
      ASSERT_EQ(got, expected) << "point " << i << " radius " << radius;
      // Capped at 10: the reference's first 10 by (distance, index), to the last tie.
      if (expected.size() > 10) expected.resize(10);
      (*fallback)->Nearest(q, {.limit_sq = radius * radius, .count = 10}, keys);
      got = as_matches(keys);
      std::sort(got.begin(), got.end(), by_distance);
      ASSERT_EQ(got, expected) << "capped ball of " << i << " radius " << radius;
    }
  }
}

}  // namespace
}  // namespace scanprep
