// SPDX-License-Identifier: Apache-2.0
// A job's plan: the steps it runs, in order, each once, with the parameters they run with;
// resolved and validated before the first step runs and immutable after.
#pragma once

#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "core/stages/params.h"
#include "core/stages/stage.h"

namespace scanprep {

class Plan {
 public:
  // The requested stages (names ValidateOptions accepted), each stage's prerequisites before it
  // and the steps it expands to (StageInfo::followers) right after it, each step once, for
  // `params` (overrides ValidateOverrides accepted).
  static absl::StatusOr<Plan> Resolve(const std::vector<std::string>& requested,
                                      ParamOverrides params);
  // A plan of exactly `steps`, refused (FAILED_PRECONDITION, naming the step and what it lacks)
  // unless every step's prerequisites come before it and no step is listed twice.
  static absl::StatusOr<Plan> FromSteps(std::vector<const StageInfo*> steps, ParamOverrides params);

  const std::vector<const StageInfo*>& steps() const { return steps_; }
  const ParamOverrides& params() const { return params_; }

 private:
  Plan(std::vector<const StageInfo*> steps, ParamOverrides params)
      : steps_(std::move(steps)), params_(std::move(params)) {}

  std::vector<const StageInfo*> steps_;
  ParamOverrides params_;
};

}  // namespace scanprep
