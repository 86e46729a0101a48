// SPDX-License-Identifier: Apache-2.0
// What a running job tells its owner about where it is.
#pragma once

#include <cstddef>
#include <functional>
#include <string_view>

namespace scanprep {

// Where a running job is: its stage, that stage's place in the plan (execution order) and
// progress, and the whole job's progress (the plan's stages weighted by their typical cost).
struct ProgressEvent {
  std::string_view stage;
  size_t stage_index = 0;     // in the plan, 0-based
  size_t stage_count = 0;     // stages in the plan
  double stage_fraction = 0;  // in [0,1]; non-decreasing within a stage
  double job_fraction = 0;    // in [0,1]; non-decreasing within a job
};
// Called from any thread, serialised; at most once per 2 % of a stage.
using ProgressFn = std::function<void(const ProgressEvent&)>;

}  // namespace scanprep
