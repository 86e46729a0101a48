// SPDX-License-Identifier: Apache-2.0
// The outlier stage's settings: its parameters (OutliersParams() in outliers.h declares them),
// shared by the paper's rule, LoOP and the surface test.
#pragma once

#include <cstdint>
#include <string_view>

#include "core/stages/param_table.h"

namespace scanprep {

// nn: the paper's global d_1 rule; loop: Local Outlier Probabilities.
enum class OutlierMethod { kNn, kLoop };

struct OutliersSettings {
  OutlierMethod method = OutlierMethod::kNn;
  double surface_sigmas = 0;  // 0: no surface test
  // The paper's rule: d (d_1, or a k-mean) above max(μ + m·σ, floor·median) of its scan.
  int64_t k = 0;                 // neighbours averaged into d
  double multiplier = 0;         // m of μ + m·σ
  double median_floor = 0;       // the threshold is at least this times median(d)
  Derived<double> threshold_mm;  // for every scan, else derived per scan
  // LoOP.
  Derived<uint32_t> loop_k;   // neighbourhood size, the shared graph's unless set
  double loop_lambda = 0;     // λ: standard deviations of the probabilistic distance
  double loop_threshold = 0;  // LoOP probability above which a point is an outlier

  bool loop() const { return method == OutlierMethod::kLoop; }
};

// The report's count of the points the stage removed, by either method.
inline constexpr std::string_view kOutliersRemoved = "outliers.removed";

}  // namespace scanprep
