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
#include "core/pipeline/params.h"

namespace scanprep {

class JobContext;

class Stage {
 public:
  virtual ~Stage() = default;
  virtual absl::Status Run(JobContext& ctx) = 0;
};

struct StageInfo {
  std::string name;
  std::string summary;
  std::vector<ParamSpec> params;
  std::function<std::unique_ptr<Stage>()> make;
  // The stages this one needs run before it with the job's parameters (the plan puts them
  // first, so progress and the report follow execution order); empty = none.
  std::function<std::vector<std::string>(const JobContext&)> prerequisites;
  // Progress: the parallel-loop items the stage meters per point, and its typical cost, which
  // weights the job fraction: both measured on the 1 M-point two-scan simulated job (`scanprep
  // simulate`, default pipeline, 2 threads; cost_weight = the stage's seconds there).
  double work_per_point = 1;
  double cost_weight = 1;
};

// Every stage the service offers, in the paper's execution order.
const std::vector<StageInfo>& StageRegistry();
const StageInfo* FindStage(std::string_view name);
// The stages' names, in StageRegistry() order (for messages naming the known ones).
std::vector<std::string> StageNames();
// All parameter specs of all stages (plus the shared neighbourhood ones).
std::vector<ParamSpec> AllParamSpecs();
const ParamSpec* FindParam(std::string_view name);

}  // namespace scanprep
