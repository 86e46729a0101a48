// SPDX-License-Identifier: Apache-2.0
// What noise alone does to a point's measures, so that the edge decision can tell an edge from
// noise (docs/algorithms.md §9 "Noise"): bounds in units of the scan's measured noise, the
// median residual of its normal fits (σ̂, MeasuredScanNoise).
#pragma once

#include <cstddef>

namespace scanprep {

// Wilson–Hilferty: the quantile of χ²_ν at the standard normal quantile z (within 1 % for ν ≥ 3).
double ChiSquareQuantile(double nu, double z);
inline constexpr double kOneSided999 = 3.09;  // the standard normal's 99.9 % quantile

// A plane fit of n_eff points with noise σ has fit_rms² ≈ σ²·χ²_ν/ν, ν = n_eff − 3 (the plane's
// three parameters), so its median fit_rms is σ·√(χ²_ν(0.5)/ν). The bounds hold at 99.9 %.
struct NoiseBounds {
  // The normals stage's fits (Gaussian weights of h = r/2 over a ball of k + 1 points) count as
  // n_eff = 0.76·(k + 1) independent points: (Σw)²/Σw² over a uniform disc.
  explicit NoiseBounds(size_t k);
  // A plane's fit_rms² stays below this times the median fit_rms²: χ²_ν(0.999)/χ²_ν(0.5).
  double fit_ms_over_median;
  // σ per median fit_rms: √(ν/χ²_ν(0.5)).
  double sigma_per_median;
  // A zero-mean Gaussian estimate stays within this many standard deviations (two-sided).
  static constexpr double kZ = 3.29;
};

}  // namespace scanprep
