// SPDX-License-Identifier: Apache-2.0
// The list of stages the service offers, in the paper's execution order (docs/algorithms.md).
#include <algorithm>

#include "core/stages/correction.h"
#include "core/stages/health.h"
#include "core/stages/measures.h"
#include "core/stages/neighbourhoods_stage.h"
#include "core/stages/normals.h"
#include "core/stages/outliers.h"
#include "core/stages/registration.h"
#include "core/stages/simplification.h"
#include "core/stages/smoothing.h"
#include "core/stages/stage.h"

namespace scanprep {

const std::vector<StageInfo>& StageRegistry() {
  static const std::vector<StageInfo> registry = {
      NeighbourhoodsStageInfo(), OutliersStageInfo(),     NormalsStageInfo(),
      MeasuresStageInfo(),       RegistrationStageInfo(), CorrectionStageInfo(),
      HealthStageInfo(),         SmoothingStageInfo(),    SimplificationStageInfo(),
  };
  return registry;
}

namespace {

// The internal stages offered stages expand to; a job cannot list them.
const std::vector<StageInfo>& InternalStages() {
  static const std::vector<StageInfo> stages = {SurfaceSpikesStageInfo()};
  return stages;
}

const StageInfo* FindIn(const std::vector<StageInfo>& list, std::string_view name) {
  auto it =
      std::find_if(list.begin(), list.end(), [&](const StageInfo& s) { return s.name == name; });
  return it == list.end() ? nullptr : &*it;
}

}  // namespace

const StageInfo* FindOfferedStage(std::string_view name) { return FindIn(StageRegistry(), name); }

const StageInfo* FindStage(std::string_view name) {
  const StageInfo* stage = FindOfferedStage(name);
  return stage != nullptr ? stage : FindIn(InternalStages(), name);
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

}  // namespace scanprep
