// SPDX-License-Identifier: Apache-2.0
// A plan's work as a multiple of the default plan's, estimated from its stages and parameters
// before any point arrives, so that parameters whose costs multiply are judged together and a job
// they make too costly is refused before it is uploaded (docs/plan-cost.md sets the model beside
// measured runs).
#pragma once

#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/pipeline/pipeline.h"
#include "core/pipeline/plan.h"

namespace scanprep {

// One parameter's share of one stage's work.
struct CostTerm {
  std::string stage;
  std::string cause;  // the overrides that set it, "smoothing.iterations=7"
  double multiplier = 1;
};

struct PlanCost {
  // Σ over the plan's stages of StageInfo::cost_weight × the product of that stage's terms,
  // over the same sum for the default plan with no overrides (1 for it).
  double ratio = 1;
  std::vector<CostTerm> terms;  // each term above 1, in plan order
};

// The estimate for `plan` (its parameters validated: ValidateOptions). A setting cheaper than its
// default is not credited (every term is at least 1); a radius the data would derive, when set, is
// judged at its bound (balls full at their cap), since the data's own radius is not known before
// the points arrive.
PlanCost EstimatePlanCost(const Plan& plan);
// The same for the plan `options` resolve to.
absl::StatusOr<PlanCost> EstimatePlanCost(const PipelineOptions& options);

// OK when `cost` is within `limit` (0 = no limit); else RESOURCE_EXHAUSTED whose message names
// the estimate, the limit and every term, largest first.
absl::Status CheckPlanCost(PlanCost cost, double limit);

}  // namespace scanprep
