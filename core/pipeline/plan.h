// SPDX-License-Identifier: Apache-2.0
// A job's plan: the stages it runs, in order, each once, with the parameters they run with;
// resolved and validated before the first stage runs and immutable after.
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
  // and the internal stages it expands to (StageInfo::followers) right after it, each once, for
  // `params` (overrides ValidateOverrides accepted).
  static absl::StatusOr<Plan> Resolve(const std::vector<std::string>& requested,
                                      ParamOverrides params);
  // A plan of exactly `stages`, refused (FAILED_PRECONDITION, naming the stage and what it
  // lacks) unless every stage's prerequisites come before it and no stage is listed twice.
  static absl::StatusOr<Plan> FromStages(std::vector<const StageInfo*> stages,
                                         ParamOverrides params);

  const std::vector<const StageInfo*>& stages() const { return stages_; }
  const ParamOverrides& params() const { return params_; }

 private:
  Plan(std::vector<const StageInfo*> stages, ParamOverrides params)
      : stages_(std::move(stages)), params_(std::move(params)) {}

  std::vector<const StageInfo*> stages_;
  ParamOverrides params_;
};

}  // namespace scanprep
