// SPDX-License-Identifier: Apache-2.0
#include "core/base/quality_order.h"

#include <optional>

namespace scanprep {

bool UniformQuality(const PointCloud& cloud, const std::vector<float>& quality) {
  std::optional<float> first;
  for (size_t i = 0; i < cloud.size(); ++i) {
    if (cloud.removed(i)) continue;
    if (!first) first = quality[i];
    if (quality[i] != *first) return false;
  }
  return true;
}

}  // namespace scanprep
