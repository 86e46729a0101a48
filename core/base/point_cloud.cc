// SPDX-License-Identifier: Apache-2.0
#include "core/base/point_cloud.h"

#include <utility>

#include <algorithm>

namespace scanprep {

size_t PointCloud::CountKept() const {
  return static_cast<size_t>(
      std::count_if(flags.begin(), flags.end(), [](uint8_t f) { return (f & kRemovedMask) == 0; }));
}

void PointCloud::FinishLoading(std::vector<uint8_t> loaded) {
  if (scan.empty()) scan.assign(size(), 0);
  if (loaded.empty()) {
    flags.assign(size(), 0);
  } else {
    flags = std::move(loaded);
  }
}

}  // namespace scanprep
