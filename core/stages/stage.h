// SPDX-License-Identifier: Apache-2.0
// A stage: its interface, what it declares (parameters, prerequisites, progress costs), and the
// registry of every stage the service offers.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "core/stages/params.h"

namespace scanprep {

class StageContext;

class Stage {
 public:
  virtual ~Stage() = default;
  virtual absl::Status Run(StageContext& ctx) = 0;
};

// The steps a stage names, as a function of the job's validated parameters only (so the plan is
// known before any stage runs).
using StepNames = std::function<std::vector<std::string>(const ParamOverrides&)>;

struct StageInfo {
  std::string name;
  std::string summary;
  std::vector<ParamSpec> params;
  std::function<std::unique_ptr<Stage>()> make;
  // The steps this one needs run before it (the plan puts them first, so progress and the report
  // follow execution order); empty = none.
  StepNames prerequisites;
  // The steps this stage expands to, planned right after it: the rest of its work that needs a
  // step run after its own (the outlier surface test needs normals fitted after LoOP's
  // removals); empty = none.
  StepNames followers;
  // Progress: the parallel-loop items the stage meters per point, and its typical cost, which
  // weights the job fraction: both measured on the 1 M-point two-scan simulated job (`scanprep
  // simulate`, default pipeline, 2 threads; cost_weight = the stage's seconds there).
  double work_per_point = 1;
  double cost_weight = 1;
};

// Every stage the service offers, in the paper's execution order.
const std::vector<StageInfo>& StageRegistry();
// A stage a job may list (options.stages); null for any other name.
const StageInfo* FindStage(std::string_view name);
// A step a plan may hold: an offered stage, or a step an offered stage expands to (followers).
const StageInfo* FindStep(std::string_view name);
// The stages' names, in StageRegistry() order (for messages naming the known ones).
std::vector<std::string> StageNames();
// All parameter specs of all stages (plus the shared neighbourhood ones).
std::vector<ParamSpec> AllParamSpecs();
const ParamSpec* FindParam(std::string_view name);
// The value a parameter will have in a job with these (validated) overrides, not recorded; for
// planning before any stage runs.
double PlannedNumber(const ParamOverrides& overrides, std::string_view name);
std::string PlannedChoiceText(const ParamOverrides& overrides, std::string_view name);
template <typename E, size_t N>
E PlannedChoice(const ParamOverrides& overrides, const ChoiceDecl<E, N>& decl) {
  return decl.Parse(PlannedChoiceText(overrides, decl.name));
}

}  // namespace scanprep
