// SPDX-License-Identifier: Apache-2.0
#include "core/spatial/median_nearest.h"

#include <algorithm>

namespace scanprep {

std::vector<double> MedianNearestDistance(const PointCloud& cloud, const Neighbourhoods& nb,
                                          const std::vector<bool>& wanted) {
  std::vector<std::vector<float>> nearest(cloud.scans.size());
  for (size_t i = 0; i < cloud.size(); ++i) {
    if (!cloud.removed(i) && (wanted.empty() || wanted[cloud.scan[i]])) {
      nearest[cloud.scan[i]].push_back(nb.knn_dist(cloud, i, 0));
    }
  }
  std::vector<double> spacing(cloud.scans.size(), 0.0);
  for (size_t s = 0; s < spacing.size(); ++s) {
    std::vector<float>& d = nearest[s];
    if (d.empty()) continue;
    std::nth_element(d.begin(), d.begin() + d.size() / 2, d.end());
    spacing[s] = d[d.size() / 2];
  }
  return spacing;
}

}  // namespace scanprep
