// SPDX-License-Identifier: Apache-2.0
#include "core/spatial/scanline_gap.h"

#include <algorithm>
#include <cmath>

namespace scanprep {
namespace {

constexpr size_t kPointsPerSample = 16;
constexpr size_t kMostSamples = 256;

// The distance from point i to the nearest point of its scan on another scanline among the
// nearest `count` within `radius`; +inf when there is none.
float NearestOtherScanline(const PointCloud& cloud, const Neighbourhoods& nb, uint32_t i,
                           float radius, size_t count, RadiusMatches& ball) {
  const float q[3] = {cloud.x[i], cloud.y[i], cloud.z[i]};
  nb.grid().Ball(q, {.limit_sq = radius * radius, .count = count}, radius, ball);
  float nearest = HUGE_VALF;
  for (const auto& [j, d2] : ball) {
    if (cloud.scan[j] == cloud.scan[i] && cloud.scanline[j] != cloud.scanline[i]) {
      nearest = std::min(nearest, d2);
    }
  }
  return std::sqrt(nearest);
}

}  // namespace

std::vector<double> ScanlineGaps(const PointCloud& cloud, const Neighbourhoods& nb,
                                 const std::vector<double>& reach) {
  const size_t scans = reach.size();
  std::vector<double> gap(scans, 0.0);
  if (!cloud.has_scanlines()) return gap;
  std::vector<size_t> count(scans, 0), seen(scans, 0), taken(scans, 0), samples(scans, 0);
  for (uint32_t i = 0; i < cloud.size(); ++i) ++count[cloud.scan[i]];
  for (size_t s = 0; s < scans; ++s) {
    if (reach[s] > 0) samples[s] = std::min(kMostSamples, count[s] / kPointsPerSample + 1);
  }
  std::vector<std::vector<float>> gaps(scans);
  RadiusMatches ball;
  for (uint32_t i = 0; i < cloud.size(); ++i) {
    const size_t s = cloud.scan[i];
    if (taken[s] == samples[s] || seen[s]++ != taken[s] * count[s] / samples[s]) continue;
    ++taken[s];
    const float d = NearestOtherScanline(cloud, nb, i, static_cast<float>(reach[s]),
                                         4 * size_t{nb.max_ball_points()}, ball);
    if (d < HUGE_VALF) gaps[s].push_back(d);
  }
  for (size_t s = 0; s < scans; ++s) {
    std::vector<float>& g = gaps[s];
    if (samples[s] == 0 || 2 * g.size() < samples[s]) continue;
    std::nth_element(g.begin(), g.begin() + g.size() / 2, g.end());
    gap[s] = g[g.size() / 2];
  }
  return gap;
}

}  // namespace scanprep
