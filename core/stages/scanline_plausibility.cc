// SPDX-License-Identifier: Apache-2.0
#include "core/stages/scanline_plausibility.h"

#include <algorithm>
#include <atomic>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/base/parallel.h"
#include "core/base/per_scan_values.h"
#include "core/base/status_macros.h"
#include "core/spatial/local_moments.h"

namespace scanprep {
namespace {

constexpr size_t kMinLinePoints = 5;
constexpr size_t kMinJudged = 32;

// 1: point i's scanline spreads as an area among its k nearest; 0: as a profile; -1: too few of
// its scanline there to tell.
int SpreadsAsArea(const PointCloud& cloud, const Neighbourhoods& nb, size_t i) {
  MomentAccumulator moments;
  const Eigen::Vector3d p = cloud.point(i).cast<double>();
  moments.Add(Eigen::Vector3d::Zero(), 1);
  size_t count = 1;
  for (const uint32_t j : nb.knn(i)) {
    if (cloud.removed(j) || cloud.scan[j] != cloud.scan[i] ||
        cloud.scanline[j] != cloud.scanline[i]) {
      continue;
    }
    moments.Add(cloud.point(j).cast<double>() - p, 1);
    ++count;
  }
  if (count < kMinLinePoints) return -1;
  const Eigen::Vector3d spread = moments.Solve().eigenvalues;
  return spread[1] > kProfileSpreadRatio * spread[2] ? 1 : 0;
}

}  // namespace

absl::Status WarnIfScanlinesImplausible(const PointCloud& cloud, const Neighbourhoods& nb,
                                        StageReporter& out) {
  if (cloud.kind != ScannerKind::kLine || !cloud.has_scanlines()) return absl::OkStatus();
  const size_t scans = cloud.scans.size();
  const std::vector<size_t> points = ScanPointCounts(cloud);
  // Every stride-th point of each scan, in index order.
  std::vector<uint32_t> sample;
  std::vector<size_t> seen(scans, 0);
  for (size_t i = 0; i < cloud.size(); ++i) {
    const uint32_t s = cloud.scan[i];
    const size_t stride = std::max<size_t>(1, points[s] / kScanlineSamplePoints);
    if (seen[s]++ % stride == 0 && !cloud.removed(i)) sample.push_back(static_cast<uint32_t>(i));
  }
  std::vector<int8_t> verdict(sample.size());
  SCANPREP_RETURN_IF_ERROR(ParallelFor(sample.size(), out.cancel(), [&](size_t begin, size_t end) {
    for (size_t v = begin; v < end; ++v) verdict[v] = SpreadsAsArea(cloud, nb, sample[v]);
  }));
  std::vector<size_t> judged(scans, 0), areas(scans, 0);
  for (size_t v = 0; v < sample.size(); ++v) {
    if (verdict[v] < 0) continue;
    ++judged[cloud.scan[sample[v]]];
    areas[cloud.scan[sample[v]]] += verdict[v];
  }
  size_t implausible = 0;
  for (size_t s = 0; s < scans; ++s) {
    if (judged[s] < kMinJudged || 2 * areas[s] <= judged[s]) continue;
    ++implausible;
    const double share = double(areas[s]) / double(judged[s]);
    out.Warn(WarningCode::kScanlinesImplausible,
             absl::StrCat("neighbourhoods: scan '", cloud.scans[s].id, "': near ",
                          absl::StrFormat("%.0f", 100 * share),
                          " % of its points their own scanline's points spread as an area, not "
                          "a profile: the scanline indices do not describe laser lines (every "
                          "point on one scanline?); send each point's profile number"),
             {{"scan", cloud.scans[s].id}, {"area_share", absl::StrFormat("%.3f", share)}});
  }
  out.Record("neighbourhoods.scans_with_implausible_scanlines", static_cast<double>(implausible));
  return absl::OkStatus();
}

}  // namespace scanprep
