// SPDX-License-Identifier: Apache-2.0
// The list of stages the service offers, in the paper's execution order (docs/algorithms.md).
#include <algorithm>

#include "core/pipeline/job_context.h"
#include "core/stages/correction.h"
#include "core/stages/measures.h"
#include "core/stages/neighbourhoods_stage.h"
#include "core/stages/normals.h"
#include "core/stages/outliers.h"
#include "core/stages/simplification.h"
#include "core/stages/smoothing.h"

namespace scanprep {

const std::vector<StageInfo>& StageRegistry() {
  static const std::vector<StageInfo> registry = {
      NeighbourhoodsStageInfo(), OutliersStageInfo(),   NormalsStageInfo(),
      MeasuresStageInfo(),       CorrectionStageInfo(), SmoothingStageInfo(),
      SimplificationStageInfo(),
  };
  return registry;
}

const StageInfo* FindStage(std::string_view name) {
  const auto& registry = StageRegistry();
  auto it = std::find_if(registry.begin(), registry.end(),
                         [&](const StageInfo& s) { return s.name == name; });
  return it == registry.end() ? nullptr : &*it;
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
