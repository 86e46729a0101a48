// SPDX-License-Identifier: Apache-2.0
// Per-point measures the measures stage leaves for the stages after it.
#pragma once

#include <optional>
#include <vector>

namespace scanprep {

// Per-point measures shared between stages (§8, §9), filled by the "measures" stage.
struct PointMeasures {
  std::vector<float> quality;            // q̂ in [0,1], 1 = frontal view
  std::vector<float> curvature;          // κ̂ in [0,1], 1 = significant edge
  std::vector<float> surface_variation;  // σ = λ0/(λ0+λ1+λ2), from the normals stage
  std::vector<float> fit_rms;            // √λ0 (mm): RMS offset of the normal fit from its plane
  // Per scan, σ̂ from fits of its own points where other scans lie over it (OwnScanNoise, filled
  // by the normals stage); MeasuredScanNoise answers with it for those scans.
  std::vector<std::optional<double>> own_scan_noise;
};

}  // namespace scanprep
