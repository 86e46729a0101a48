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

// The stages a stage names, as a function of the job's validated parameters only (so the plan is
// known before any stage runs).
using StagesFor = std::function<std::vector<std::string>(const ParamOverrides&)>;

struct StageInfo {
  std::string name;
  std::string summary;
  std::vector<ParamSpec> params;
  std::function<std::unique_ptr<Stage>()> make;
  // The stages this one needs run before it (the plan puts them first, so progress and the report
  // follow execution order); empty = none.
  StagesFor prerequisites;
  // The internal stages this one expands to, planned right after it: the rest of its work that
  // needs a stage run after its own (the outlier surface test needs normals fitted after LoOP's
  // removals); empty = none.
  StagesFor followers;
  // Progress: the parallel-loop items the stage meters per point, and its typical cost, which
  // weights the job fraction: both measured on the 1 M-point two-scan simulated job (`scanprep
  // simulate`, default pipeline, 2 threads; cost_weight = the stage's seconds there).
  double work_per_point = 1;
  double cost_weight = 1;
};

// Every stage the service offers, in the paper's execution order.
const std::vector<StageInfo>& StageRegistry();
// A stage a job may list (options.stages), an offered one; null for any other name.
const StageInfo* FindOfferedStage(std::string_view name);
// A stage a plan may hold: an offered stage, or an internal one an offered stage expands to
// (followers).
const StageInfo* FindStage(std::string_view name);
// The stages' names, in StageRegistry() order (for messages naming the known ones).
std::vector<std::string> StageNames();
// All parameter specs of all stages (plus the shared neighbourhood ones).
std::vector<ParamSpec> AllParamSpecs();
const ParamSpec* FindParam(std::string_view name);
}  // namespace scanprep
