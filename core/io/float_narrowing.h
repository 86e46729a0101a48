// SPDX-License-Identifier: Apache-2.0
// double -> float without undefined behaviour: out-of-range values saturate to ±infinity (what
// IEEE rounding gives, but a plain cast of an unrepresentable value is UB in C++ and trips
// -fsanitize=float-cast-overflow when fuzzing).
#pragma once

#include <limits>

namespace scanprep::io {

inline float NarrowToFloat(double value) {
  constexpr double kMax = std::numeric_limits<float>::max();
  if (value > kMax) return std::numeric_limits<float>::infinity();
  if (value < -kMax) return -std::numeric_limits<float>::infinity();
  return static_cast<float>(value);
}

}  // namespace scanprep::io
