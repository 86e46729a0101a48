// SPDX-License-Identifier: Apache-2.0
#include "core/stages/noise_bounds.h"

#include <algorithm>
#include <cmath>

namespace scanprep {
double ChiSquareQuantile(double nu, double z) {
  const double c = 2.0 / (9.0 * nu);
  return nu * std::pow(1 - c + z * std::sqrt(c), 3);
}

NoiseBounds::NoiseBounds(size_t k) {
  const double nu = std::max(3.0, 0.76 * double(k + 1) - 3);
  const double median = ChiSquareQuantile(nu, 0);
  fit_ms_over_median = ChiSquareQuantile(nu, kOneSided999) / median;
  sigma_per_median = std::sqrt(nu / median);
}

}  // namespace scanprep
