// SPDX-License-Identifier: Apache-2.0
#include "core/stages/scan_noise.h"

#include <algorithm>

namespace scanprep {

std::vector<std::optional<double>> MeasuredScanNoise(const PointCloud& cloud,
                                                     const PointMeasures& m, size_t scans,
                                                     uint8_t skip) {
  std::vector<std::vector<float>> residuals(scans);
  for (size_t i = 0; i < cloud.size(); ++i) {
    if (cloud.flags[i] & (skip | kNormalInvalid)) continue;
    residuals[cloud.scan[i]].push_back(m.fit_rms[i]);
  }
  std::vector<std::optional<double>> noise(scans);
  for (size_t s = 0; s < scans; ++s) {
    std::vector<float>& r = residuals[s];
    if (r.size() < kMinNoiseSamples) continue;
    std::nth_element(r.begin(), r.begin() + r.size() / 2, r.end());
    if (r[r.size() / 2] > 0) noise[s] = r[r.size() / 2];
  }
  return noise;
}

}  // namespace scanprep
