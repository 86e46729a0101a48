// SPDX-License-Identifier: Apache-2.0
#include "core/stages/scan_spacing.h"

#include "core/base/status_macros.h"
#include "core/spatial/median_nearest.h"
#include "core/stages/scanline_curvature.h"

namespace scanprep {

absl::StatusOr<std::vector<double>> ScanPointSpacing(const PointCloud& cloud,
                                                     const Neighbourhoods* nb,
                                                     const CancelToken& cancel) {
  SCANPREP_ASSIGN_OR_RETURN(std::vector<double> spacing, MedianScanlineSpacing(cloud, cancel));
  std::vector<bool> unknown(spacing.size());
  for (size_t s = 0; s < spacing.size(); ++s) {
    if (spacing[s] == 0) spacing[s] = cloud.scans[s].point_spacing;
    unknown[s] = spacing[s] == 0;
  }
  if (nb == nullptr || nb->k() == 0) return spacing;
  SCANPREP_ASSIGN_OR_RETURN(const std::vector<double> measured,
                            MedianNearestDistance(cloud, *nb, cancel, unknown));
  for (size_t s = 0; s < spacing.size(); ++s) {
    if (unknown[s]) spacing[s] = measured[s];
  }
  return spacing;
}

}  // namespace scanprep
