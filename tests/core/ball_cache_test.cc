// SPDX-License-Identifier: Apache-2.0
// The ball cache must answer what the grid answers (the ball now, without the points removed
// since), whether a ball was kept in it or left beyond its budget; and the budget must hold when
// every ball is at its cap (a radius far beyond the data's scale), with a control at the
// ordinary radius where everything fits.
#include "core/spatial/ball_cache.h"

#include <algorithm>

#include <gtest/gtest.h>

#include "core/sim/scan_simulator.h"
#include "core/spatial/neighbourhoods.h"

namespace scanprep {
namespace {

PointCloud BoxScans(size_t points) {
  const auto part = sim::Part::kBoxWithBore;
  return sim::SimulateWithPointCount(part, sim::TwoOverlappingSensors(part), points, 0.01, 3).cloud;
}

std::vector<uint32_t> Members(const RadiusMatches& matches) {
  std::vector<uint32_t> ids;
  for (const auto& match : matches) ids.push_back(match.first);
  std::sort(ids.begin(), ids.end());
  return ids;
}

struct Gathered {
  std::unique_ptr<Neighbourhoods> nb;
  BallCache cache;
};

// Gathers every ball of `radius` that spans two scans, then removes every 5th point.
void Gather(PointCloud& cloud, float radius, Gathered& g) {
  auto nb = Neighbourhoods::Build(cloud, {}, CancelToken());
  ASSERT_TRUE(nb.ok()) << nb.status();
  g.nb = *std::move(nb);
  const std::vector<float> radii(cloud.scans.size(), radius);
  auto spans = [&](const RadiusMatches& m) {
    return std::any_of(m.begin(), m.end(), [&](const auto& x) {
      return cloud.scan[x.first] != cloud.scan[m[0].first];
    });
  };
  ASSERT_TRUE(g.cache.Gather(cloud, *g.nb, radii, spans, CancelToken()).ok());
  for (size_t i = 0; i < cloud.size(); i += 5) cloud.flags[i] |= kRemovedMerge;
}

// Every ball the cache answers is the grid's, with the same distances. A ball capped when it was
// gathered (its nearest max_ball_points()) lacks the points beyond the cap that a ball asked now,
// after removals, may reach: for those (`capped`) the answer is a subset of the uncapped ball.
size_t ExpectGridBalls(const PointCloud& cloud, const Gathered& g, float radius, bool capped) {
  RadiusMatches cached, grid;
  size_t compared = 0;
  for (size_t i = 1; i < cloud.size(); i += 3) {
    if (cloud.removed(i) || g.cache.Rejected(i) || radius <= g.nb->dk(i)) continue;
    g.cache.Within(cloud, *g.nb, i, radius, cached);
    for (const auto& [j, d2] : cached) EXPECT_EQ(d2, cloud.squared_distance(i, j));
    if (capped) {
      g.nb->WithinUncapped(cloud, i, radius, grid);
      const std::vector<uint32_t> all = Members(grid);
      const std::vector<uint32_t> got = Members(cached);
      EXPECT_TRUE(std::includes(all.begin(), all.end(), got.begin(), got.end())) << "point " << i;
    } else {
      g.nb->Within(cloud, i, radius, grid);
      EXPECT_EQ(Members(cached), Members(grid)) << "point " << i;
    }
    ++compared;
  }
  return compared;
}

TEST(BallCache, AnswersTheGridsBallsWithinItsBudget) {
  PointCloud cloud = BoxScans(60'000);
  Gathered g;
  Gather(cloud, 0.f, g);  // radius set below, once r_g is known
  const float radius = static_cast<float>(1.5 * g.nb->global_radius());
  cloud = BoxScans(60'000);
  Gather(cloud, radius, g);
  EXPECT_GT(g.cache.kept(), 1000u);
  EXPECT_EQ(g.cache.over_budget(), 0u);  // the control: an ordinary radius fits
  EXPECT_LT(g.cache.bytes(), kBallCacheBytesPerPoint * cloud.size());
  EXPECT_GT(ExpectGridBalls(cloud, g, radius, false), 1000u);
}

TEST(BallCache, BallsAtTheirCapStayWithinTheBudget) {
  PointCloud cloud = BoxScans(20'000);
  Gathered g;
  Gather(cloud, 0.f, g);
  // Every ball at its cap of max_ball_points(), 640 points.
  const float radius = static_cast<float>(20 * g.nb->global_radius());
  cloud = BoxScans(20'000);
  Gather(cloud, radius, g);
  EXPECT_GT(g.cache.over_budget(), 0u);
  EXPECT_GT(g.cache.kept(), 0u);
  // At most one round of balls beyond the budget, each at most 5 bytes a member.
  const size_t round = BallCache::PointsPerRound() * (5 * g.nb->max_ball_points() + 5);
  EXPECT_LE(g.cache.bytes(), kBallCacheBytesPerPoint * cloud.size() + round);
  EXPECT_GT(ExpectGridBalls(cloud, g, radius, true), 500u);
}

}  // namespace
}  // namespace scanprep
