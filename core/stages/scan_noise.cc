// SPDX-License-Identifier: Apache-2.0
#include "core/stages/scan_noise.h"

#include <algorithm>

#include "core/base/per_scan_values.h"

namespace scanprep {

absl::StatusOr<std::vector<std::optional<double>>> MeasuredScanNoise(const PointCloud& cloud,
                                                                     const PointMeasures& m,
                                                                     size_t scans,
                                                                     const CancelToken& cancel,
                                                                     uint8_t skip) {
  SCANPREP_ASSIGN_OR_RETURN(
      std::vector<std::vector<float>> residuals,
      ValuesPerScan(cloud, cloud.size(), cancel, [&](size_t i, const auto& add) {
        if (!(cloud.flags[i] & (skip | kNormalInvalid))) add(cloud.scan[i], m.fit_rms[i]);
      }));
  std::vector<std::optional<double>> noise(scans);
  // `scans` may exceed the cloud's (callers ask for at least one): those have no points.
  for (size_t s = 0; s < std::min(scans, residuals.size()); ++s) {
    if (s < m.own_scan_noise.size() && m.own_scan_noise[s]) {
      noise[s] = m.own_scan_noise[s];
      continue;
    }
    std::vector<float>& r = residuals[s];
    if (r.size() < kMinNoiseSamples) continue;
    const float median = UpperMedian(r);
    if (median > 0) noise[s] = median;
  }
  return noise;
}

}  // namespace scanprep
