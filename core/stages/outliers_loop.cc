// SPDX-License-Identifier: Apache-2.0
// σ(o) = √(mean of squared distances to the k nearest neighbours), pdist = λ·σ,
// PLOF(o) = pdist(o) / mean pdist(N_k(o)) − 1, nPLOF = λ·√(mean PLOF²),
// LoOP = max(0, erf(PLOF / (nPLOF·√2))). Removed neighbours are skipped; the k nearest
// unremoved ones among the shared graph are used.
#include "core/stages/outliers_loop.h"

#include <algorithm>
#include <atomic>
#include <cmath>

#include "core/base/parallel.h"
#include "core/base/status_macros.h"

namespace scanprep {

absl::Status RemoveLoopOutliers(PointCloud& cloud, const Neighbourhoods& nb,
                                const OutliersSettings& settings, StageReporter& out) {
  const size_t n = cloud.size();
  // At most neighbourhoods.k (ValidateOverrides); for_neighbours() takes what the graph holds.
  const uint32_t k = settings.loop_k.Or(nb.k());
  out.Record(settings.loop_k.name, k);
  const double lambda = settings.loop_lambda;

  // Visits the first k unremoved neighbours of i.
  auto for_neighbours = [&](size_t i, auto&& visit) {
    const auto idx = nb.knn(i);
    uint32_t used = 0;
    for (uint32_t m = 0; m < nb.k() && used < k; ++m) {
      if (cloud.removed(idx[m])) continue;
      visit(idx[m], idx.dist(cloud, m));
      ++used;
    }
    return used;
  };

  std::vector<double> pdist(n, 0.0);
  SCANPREP_RETURN_IF_ERROR(ParallelFor(n, out.cancel(), [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      if (cloud.removed(i)) continue;
      double sum_sq = 0;
      const uint32_t used = for_neighbours(i, [&](uint32_t, float d) { sum_sq += double(d) * d; });
      pdist[i] = used ? lambda * std::sqrt(sum_sq / used) : 0.0;
    }
  }));

  std::vector<double> plof(n, 0.0);
  std::atomic<double> total_sq{0.0};
  std::atomic<size_t> count{0};
  SCANPREP_RETURN_IF_ERROR(ParallelFor(n, out.cancel(), [&](size_t begin, size_t end) {
    double local_sq = 0;
    size_t local_count = 0;
    for (size_t i = begin; i < end; ++i) {
      if (cloud.removed(i)) continue;
      double sum = 0;
      const uint32_t used = for_neighbours(i, [&](uint32_t j, float) { sum += pdist[j]; });
      // Duplicates give pdist 0 on both sides: no evidence either way.
      plof[i] = used && sum > 0 ? pdist[i] / (sum / used) - 1.0 : 0.0;
      local_sq += plof[i] * plof[i];
      ++local_count;
    }
    total_sq.fetch_add(local_sq);
    count += local_count;
  }));
  const double nplof = count ? lambda * std::sqrt(total_sq / count) : 0.0;
  out.Record("outliers.loop_nplof", nplof);
  if (!(nplof > 0)) {
    out.Record(kOutliersRemoved, 0);
    return absl::OkStatus();
  }

  size_t removed = 0;
  for (size_t i = 0; i < n; ++i) {
    if (cloud.removed(i)) continue;
    const double loop = std::max(0.0, std::erf(plof[i] / (nplof * std::sqrt(2.0))));
    if (loop > settings.loop_threshold) {
      cloud.flags[i] |= kRemovedOutlier;
      ++removed;
    }
  }
  out.Record(kOutliersRemoved, static_cast<double>(removed));
  return absl::OkStatus();
}

}  // namespace scanprep
