// SPDX-License-Identifier: Apache-2.0
// The list of stages the service offers, in the paper's execution order (docs/algorithms.md).
#include <algorithm>

#include "absl/strings/numbers.h"
#include "core/stages/correction.h"
#include "core/stages/health.h"
#include "core/stages/measures.h"
#include "core/stages/neighbourhoods_stage.h"
#include "core/stages/normals.h"
#include "core/stages/outliers.h"
#include "core/stages/simplification.h"
#include "core/stages/smoothing.h"
#include "core/stages/stage.h"

namespace scanprep {

const std::vector<StageInfo>& StageRegistry() {
  static const std::vector<StageInfo> registry = {
      NeighbourhoodsStageInfo(), OutliersStageInfo(),       NormalsStageInfo(),
      MeasuresStageInfo(),       CorrectionStageInfo(),     HealthStageInfo(),
      SmoothingStageInfo(),      SimplificationStageInfo(),
  };
  return registry;
}

namespace {

// The steps offered stages expand to; a job cannot list them.
const std::vector<StageInfo>& ExpansionSteps() {
  static const std::vector<StageInfo> steps = {SurfaceSpikesStepInfo()};
  return steps;
}

const StageInfo* FindIn(const std::vector<StageInfo>& list, std::string_view name) {
  auto it =
      std::find_if(list.begin(), list.end(), [&](const StageInfo& s) { return s.name == name; });
  return it == list.end() ? nullptr : &*it;
}

}  // namespace

const StageInfo* FindStage(std::string_view name) { return FindIn(StageRegistry(), name); }

const StageInfo* FindStep(std::string_view name) {
  const StageInfo* stage = FindStage(name);
  return stage != nullptr ? stage : FindIn(ExpansionSteps(), name);
}

std::vector<std::string> StageNames() {
  std::vector<std::string> names;
  for (const StageInfo& stage : StageRegistry()) names.push_back(stage.name);
  return names;
}

std::vector<ParamSpec> AllParamSpecs() {
  std::vector<ParamSpec> specs;
  for (const StageInfo& stage : StageRegistry()) {
    specs.insert(specs.end(), stage.params.begin(), stage.params.end());
  }
  return specs;
}

const ParamSpec* FindParam(std::string_view name) {
  for (const StageInfo& stage : StageRegistry()) {
    for (const ParamSpec& spec : stage.params) {
      if (spec.name == name) return &spec;
    }
  }
  return nullptr;
}

double PlannedNumber(const ParamOverrides& overrides, std::string_view name) {
  auto it = overrides.find(name);
  double value = 0;
  if (it != overrides.end() && absl::SimpleAtod(it->second, &value)) return value;
  return FindParam(name)->default_value.value_or(0);
}

std::string PlannedChoiceText(const ParamOverrides& overrides, std::string_view name) {
  auto it = overrides.find(name);
  return it != overrides.end() ? it->second : FindParam(name)->choices.front();
}

}  // namespace scanprep
