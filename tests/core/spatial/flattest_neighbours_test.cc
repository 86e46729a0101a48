// SPDX-License-Identifier: Apache-2.0
// The flattest neighbours are the `count` matches of lowest surface variation (ties: lower index),
// without the excluded point and without points whose normal is invalid: checked against a full
// sort of the qualifying matches, with ties, invalid normals, and fewer matches than asked for.
#include "core/spatial/flattest_neighbours.h"

#include <algorithm>
#include <random>

#include <gtest/gtest.h>

namespace scanprep {
namespace {

using Flattest = std::vector<std::pair<float, uint32_t>>;

// The reference: every qualifying match, sorted, cut to `count`.
Flattest FullSort(const PointCloud& cloud, const PointMeasures& m, const RadiusMatches& matches,
                  size_t exclude, size_t count) {
  Flattest all;
  for (const auto& [j, d2] : matches) {
    if (j != exclude && !(cloud.flags[j] & kNormalInvalid)) {
      all.emplace_back(m.surface_variation[j], j);
    }
  }
  std::sort(all.begin(), all.end());
  all.resize(std::min(all.size(), count));
  return all;
}

TEST(FlattestNeighbours, TheLowestSurfaceVariationsInOrderWithoutExcludedOrInvalid) {
  constexpr size_t kPoints = 400;
  PointCloud cloud;
  cloud.x.assign(kPoints, 0.f), cloud.y.assign(kPoints, 0.f), cloud.z.assign(kPoints, 0.f);
  cloud.FinishLoading();
  PointMeasures m;
  std::mt19937 rng(3);
  // Few distinct values, so ties are common and the index must break them.
  std::uniform_int_distribution<int> level(0, 9), coin(0, 4);
  for (size_t i = 0; i < kPoints; ++i) {
    m.surface_variation.push_back(0.01f * level(rng));
    if (coin(rng) == 0) cloud.flags[i] |= kNormalInvalid;
  }
  size_t invalid_among_best = 0;
  for (int trial = 0; trial < 200; ++trial) {
    RadiusMatches matches;
    const size_t size = trial % 70;
    for (size_t k = 0; k < size; ++k) matches.emplace_back(rng() % kPoints, 1.f);
    std::sort(matches.begin(), matches.end());
    matches.erase(std::unique(matches.begin(), matches.end()), matches.end());
    std::shuffle(matches.begin(), matches.end(), rng);
    const size_t exclude = matches.empty() ? 0 : matches[trial % matches.size()].first;
    for (size_t count : {size_t{0}, size_t{1}, size_t{7}, size_t{8}, size_t{100}}) {
      Flattest out{{-1.f, 0}};  // stale content must go
      FlattestNeighbours(cloud, m, matches, exclude, count, out);
      EXPECT_EQ(out, FullSort(cloud, m, matches, exclude, count))
          << "trial " << trial << ", count " << count;
    }
    // Control: without the validity rule the answer would differ in some trials.
    Flattest any;
    for (const auto& [j, d2] : matches) {
      if (j != exclude) any.emplace_back(m.surface_variation[j], j);
    }
    std::sort(any.begin(), any.end());
    any.resize(std::min<size_t>(any.size(), 8));
    for (const auto& [sv, j] : any) invalid_among_best += (cloud.flags[j] & kNormalInvalid) != 0;
  }
  EXPECT_GT(invalid_among_best, 50u);
}

}  // namespace
}  // namespace scanprep
