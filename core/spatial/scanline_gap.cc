// SPDX-License-Identifier: Apache-2.0
#include "core/spatial/scanline_gap.h"

#include <algorithm>
#include <cmath>

#include "core/base/parallel.h"
#include "core/base/status_macros.h"

namespace scanprep {
namespace {

constexpr size_t kPointsPerSample = 64;
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

// The sampled points of the scans with reach > 0: evenly over each scan, in index order.
std::vector<uint32_t> Samples(const PointCloud& cloud, const std::vector<double>& reach) {
  const size_t scans = reach.size();
  std::vector<size_t> count(scans, 0), seen(scans, 0), taken(scans, 0), wanted(scans, 0);
  for (uint32_t i = 0; i < cloud.size(); ++i) ++count[cloud.scan[i]];
  for (size_t s = 0; s < scans; ++s) {
    if (reach[s] > 0) wanted[s] = std::min(kMostSamples, count[s] / kPointsPerSample + 1);
  }
  std::vector<uint32_t> samples;
  for (uint32_t i = 0; i < cloud.size(); ++i) {
    const size_t s = cloud.scan[i];
    if (taken[s] == wanted[s] || seen[s]++ != taken[s] * count[s] / wanted[s]) continue;
    ++taken[s];
    samples.push_back(i);
  }
  return samples;
}

}  // namespace

absl::StatusOr<std::vector<double>> ScanlineGaps(const PointCloud& cloud, const Neighbourhoods& nb,
                                                 const std::vector<double>& reach,
                                                 const CancelToken& cancel) {
  std::vector<double> gap(reach.size(), 0.0);
  // No scan to measure (the usual case: every requested r_min within the limit): no pass over
  // the points at all.
  if (!cloud.has_scanlines() ||
      std::none_of(reach.begin(), reach.end(), [](double r) { return r > 0; })) {
    return gap;
  }
  const std::vector<uint32_t> samples = Samples(cloud, reach);
  std::vector<float> found(samples.size());
  SCANPREP_RETURN_IF_ERROR(ParallelFor(
      samples.size(), cancel,
      [&](size_t begin, size_t end) {
        RadiusMatches ball;
        for (size_t m = begin; m < end; ++m) {
          const uint32_t i = samples[m];
          found[m] = NearestOtherScanline(cloud, nb, i, static_cast<float>(reach[cloud.scan[i]]),
                                          4 * size_t{nb.max_ball_points()}, ball);
        }
      },
      /*grain=*/8));
  std::vector<std::vector<float>> gaps(reach.size());
  std::vector<size_t> sampled(reach.size(), 0);
  for (size_t m = 0; m < samples.size(); ++m) {
    const size_t s = cloud.scan[samples[m]];
    ++sampled[s];
    if (found[m] < HUGE_VALF) gaps[s].push_back(found[m]);
  }
  for (size_t s = 0; s < reach.size(); ++s) {
    std::vector<float>& g = gaps[s];
    if (sampled[s] == 0 || 2 * g.size() < sampled[s]) continue;
    std::nth_element(g.begin(), g.begin() + g.size() / 2, g.end());
    gap[s] = g[g.size() / 2];
  }
  return gap;
}

}  // namespace scanprep
