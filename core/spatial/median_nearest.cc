// SPDX-License-Identifier: Apache-2.0
#include "core/spatial/median_nearest.h"

#include "core/base/per_scan_values.h"

namespace scanprep {

absl::StatusOr<std::vector<double>> MedianNearestDistance(const PointCloud& cloud,
                                                          const Neighbourhoods& nb,
                                                          const CancelToken& cancel,
                                                          const std::vector<bool>& wanted) {
  SCANPREP_ASSIGN_OR_RETURN(
      std::vector<std::vector<float>> nearest,
      ValuesPerScan(cloud, cloud.size(), cancel, [&](size_t i, const auto& add) {
        if (!cloud.removed(i) && (wanted.empty() || wanted[cloud.scan[i]])) {
          add(cloud.scan[i], nb.knn_dist(cloud, i, 0));
        }
      }));
  std::vector<double> spacing(cloud.scans.size(), 0.0);
  for (size_t s = 0; s < spacing.size(); ++s) spacing[s] = UpperMedian(nearest[s]);
  return spacing;
}

}  // namespace scanprep
