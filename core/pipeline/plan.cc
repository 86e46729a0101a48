// SPDX-License-Identifier: Apache-2.0
#include "core/pipeline/plan.h"

#include <algorithm>
#include <functional>

#include "absl/strings/str_cat.h"
#include "core/base/status_macros.h"

namespace scanprep {
namespace {

bool Holds(const std::vector<const StageInfo*>& stages, size_t before, std::string_view name) {
  return std::any_of(stages.begin(), stages.begin() + before,
                     [&](const StageInfo* s) { return s->name == name; });
}

}  // namespace

absl::StatusOr<Plan> Plan::Resolve(const std::vector<std::string>& requested,
                                   ParamOverrides params) {
  std::vector<const StageInfo*> stages;
  absl::Status unknown;
  // Depth-first: a stage's prerequisites (theirs first) before it, its followers after it.
  // Prerequisites only name stages whose own ones lead back to neighbourhoods, never to the asking
  // stage (Plan tests check every stage), so the recursion ends.
  std::function<void(std::string_view)> add = [&](std::string_view name) {
    const StageInfo* info = FindStage(name);
    if (info == nullptr) {
      unknown =
          absl::InvalidArgumentError(absl::StrCat("no stage named '", std::string(name), "'"));
      return;
    }
    if (std::find(stages.begin(), stages.end(), info) != stages.end()) return;
    if (info->prerequisites) {
      for (const std::string& need : info->prerequisites(params)) add(need);
    }
    stages.push_back(info);
    if (info->followers) {
      for (const std::string& next : info->followers(params)) add(next);
    }
  };
  for (const std::string& name : requested) add(name);
  SCANPREP_RETURN_IF_ERROR(unknown);
  return FromStages(std::move(stages), std::move(params));
}

absl::StatusOr<Plan> Plan::FromStages(std::vector<const StageInfo*> stages, ParamOverrides params) {
  for (size_t i = 0; i < stages.size(); ++i) {
    const StageInfo& stage = *stages[i];
    if (Holds(stages, i, stage.name)) {
      return absl::FailedPreconditionError(
          absl::StrCat("plan stage ", i, " '", stage.name, "' is listed twice"));
    }
    if (!stage.prerequisites) continue;
    for (const std::string& need : stage.prerequisites(params)) {
      if (!Holds(stages, i, need)) {
        return absl::FailedPreconditionError(
            absl::StrCat("plan stage ", i, " '", stage.name, "' needs stage '", need,
                         "' before it, and the plan does not run it there"));
      }
    }
  }
  return Plan(std::move(stages), std::move(params));
}

}  // namespace scanprep
