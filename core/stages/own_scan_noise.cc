// SPDX-License-Identifier: Apache-2.0
// The cost is bounded by the sample, not by the overlap: at most kSampleBudget sampled points in
// all (at least kMinSamplesPerScan a scan), each reading at most kMaxCandidates points of the
// shared grid to find its scan's k + 1 nearest among the others'.
#include "core/stages/own_scan_noise.h"

#include <algorithm>
#include <cmath>

#include "core/base/parallel.h"
#include "core/base/per_scan_values.h"
#include "core/base/status_macros.h"
#include "core/base/stride.h"
#include "core/spatial/ball_fit.h"
#include "core/stages/scan_noise.h"

namespace scanprep {
namespace {

constexpr size_t kSampleBudget = 8192;
constexpr size_t kMinSamplesPerScan = 64;
constexpr size_t kMaxSamplesPerScan = 1024;
constexpr size_t kMaxCandidates = 65536;
// Searches widen the radius this many times at most (×2 each) before a sample is given up.
constexpr int kWidenings = 4;

// Up to `cap` points of each scan, evenly strided over its index order.
std::vector<std::vector<uint32_t>> StridedSamples(const PointCloud& cloud, size_t cap) {
  const std::vector<size_t> count = ScanPointCounts(cloud);
  std::vector<std::vector<uint32_t>> samples(cloud.scans.size());
  std::vector<size_t> seen(cloud.scans.size(), 0);
  for (uint32_t i = 0; i < cloud.size(); ++i) {
    const uint32_t s = cloud.scan[i];
    const size_t stride = std::max<size_t>(1, count[s] / cap);
    if (seen[s]++ % stride == 0 && samples[s].size() < cap) samples[s].push_back(i);
  }
  return samples;
}

// The share of i's k-NN list that is of i's own scan.
double OwnShare(const PointCloud& cloud, const Neighbourhoods& nb, uint32_t i) {
  const KnnList list = nb.knn(i);
  if (list.size() == 0) return 1;
  size_t own = 0;
  for (const uint32_t j : list) own += cloud.scan[j] == cloud.scan[i];
  return double(own) / double(list.size());
}

// i's own-scan points within `radius`, nearest first, or nothing when the grid holds more
// candidates there than kMaxCandidates.
bool OwnWithin(const PointCloud& cloud, const Neighbourhoods& nb, uint32_t i, float radius,
               RadiusMatches& out) {
  out.clear();
  const float q[3] = {cloud.x[i], cloud.y[i], cloud.z[i]};
  const NearestQuery query{.limit_sq = radius * radius,
                           .count = kMaxCandidates,
                           .flags = cloud.flags.data(),
                           .skip = kRemovedMask};
  if (nb.grid().Ball(q, query, radius, out) > 0) return false;
  std::erase_if(out, [&](const auto& m) { return cloud.scan[m.first] != cloud.scan[i]; });
  std::sort(out.begin(), out.end(),
            [](const auto& a, const auto& b) { return a.second < b.second; });
  return true;
}

// The RMS residual of i's fit on its own scan's points, as the normals stage fits a point of a
// scan alone; nothing when the search gives up or the fit fails.
std::optional<float> OwnFitResidual(const PointCloud& cloud, const Neighbourhoods& nb, uint32_t i,
                                    double h_factor, RadiusMatches& own) {
  const size_t k = nb.k();
  // The radius that holds k + 1 own points if the list's share holds beyond it, and some margin.
  const double share = std::max(OwnShare(cloud, nb, i), 0.5 / double(std::max<size_t>(k, 1)));
  float radius = static_cast<float>(1.25 * nb.dk(i) * std::sqrt(1 / share));
  for (int widen = 0;; ++widen) {
    if (!OwnWithin(cloud, nb, i, radius, own)) return std::nullopt;
    if (own.size() > k) break;
    if (widen == kWidenings || !(radius > 0)) return std::nullopt;
    radius *= 2;
  }
  const float r = std::max(nb.min_radius(i), std::sqrt(own[k].second));
  if (r > radius && !OwnWithin(cloud, nb, i, r, own)) return std::nullopt;
  const float r2 = r * r;
  std::erase_if(own, [&](const auto& m) { return m.second > r2; });
  // As the normals stage's sampled ball: at most the cap, evenly over the ball (strided by
  // distance, which keeps the distances' spread), not the nearest, whose smaller disc fits tighter.
  own = Stride(own, kSamplePointsPerNeighbour * (k + 1));
  const LocalFrame frame = FitBall(cloud, i, h_factor * r, own);
  if (!frame.valid) return std::nullopt;
  return static_cast<float>(std::sqrt(std::max(0.0, frame.eigenvalues[0])));
}

}  // namespace

absl::StatusOr<std::vector<std::optional<double>>> OwnScanNoise(const PointCloud& cloud,
                                                                const Neighbourhoods& nb,
                                                                double h_factor,
                                                                const CancelToken& cancel) {
  const size_t scans = cloud.scans.size();
  std::vector<std::optional<double>> noise(scans);
  if (scans < 2) return noise;
  // One pass over the points for every scan's sample; which scans' k-NN lists are mostly other
  // scans' is judged on a smaller even part of it.
  const std::vector<std::vector<uint32_t>> candidates = StridedSamples(cloud, kMaxSamplesPerScan);
  std::vector<bool> overlapped(scans, false);
  for (size_t s = 0; s < scans; ++s) {
    const std::vector<uint32_t> probe = Stride(candidates[s], kMinSamplesPerScan);
    double share = 0;
    for (const uint32_t i : probe) share += OwnShare(cloud, nb, i);
    overlapped[s] = !probe.empty() && share < kOwnShareForNormalsFits * double(probe.size());
  }
  const size_t measured = std::count(overlapped.begin(), overlapped.end(), true);
  if (measured == 0) return noise;
  const size_t per_scan =
      std::clamp(kSampleBudget / measured, kMinSamplesPerScan, kMaxSamplesPerScan);
  std::vector<std::vector<uint32_t>> samples(scans);
  for (size_t s = 0; s < scans; ++s) {
    if (overlapped[s]) samples[s] = Stride(candidates[s], per_scan);
  }
  std::vector<uint32_t> flat;
  for (const auto& s : samples) flat.insert(flat.end(), s.begin(), s.end());
  std::vector<float> residual(flat.size(), -1.f);
  SCANPREP_RETURN_IF_ERROR(ParallelFor(
      flat.size(), cancel,
      [&](size_t begin, size_t end) {
        RadiusMatches own;
        for (size_t at = begin; at < end; ++at) {
          if (cloud.removed(flat[at])) continue;
          if (auto r = OwnFitResidual(cloud, nb, flat[at], h_factor, own)) residual[at] = *r;
        }
      },
      8));
  std::vector<std::vector<float>> per_scan_residuals(scans);
  for (size_t at = 0; at < flat.size(); ++at) {
    if (residual[at] >= 0) per_scan_residuals[cloud.scan[flat[at]]].push_back(residual[at]);
  }
  for (size_t s = 0; s < scans; ++s) {
    std::vector<float>& r = per_scan_residuals[s];
    if (r.size() >= kMinNoiseSamples) noise[s] = UpperMedian(r);
  }
  return noise;
}

}  // namespace scanprep
