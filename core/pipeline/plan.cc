// SPDX-License-Identifier: Apache-2.0
#include "core/pipeline/plan.h"

#include <algorithm>
#include <functional>

#include "absl/strings/str_cat.h"
#include "core/base/status_macros.h"

namespace scanprep {
namespace {

bool Holds(const std::vector<const StageInfo*>& steps, size_t before, std::string_view name) {
  return std::any_of(steps.begin(), steps.begin() + before,
                     [&](const StageInfo* s) { return s->name == name; });
}

}  // namespace

absl::StatusOr<Plan> Plan::Resolve(const std::vector<std::string>& requested,
                                   ParamOverrides params) {
  std::vector<const StageInfo*> steps;
  absl::Status unknown;
  // Depth-first: a step's prerequisites (theirs first) before it, its followers after it.
  // Prerequisites only name steps whose own ones lead back to neighbourhoods, never to the asking
  // step (Plan tests check every stage), so the recursion ends.
  std::function<void(std::string_view)> add = [&](std::string_view name) {
    const StageInfo* info = FindStep(name);
    if (info == nullptr) {
      unknown = absl::InvalidArgumentError(
          absl::StrCat("no stage or step named '", std::string(name), "'"));
      return;
    }
    if (std::find(steps.begin(), steps.end(), info) != steps.end()) return;
    if (info->prerequisites) {
      for (const std::string& need : info->prerequisites(params)) add(need);
    }
    steps.push_back(info);
    if (info->followers) {
      for (const std::string& next : info->followers(params)) add(next);
    }
  };
  for (const std::string& name : requested) add(name);
  SCANPREP_RETURN_IF_ERROR(unknown);
  return FromSteps(std::move(steps), std::move(params));
}

absl::StatusOr<Plan> Plan::FromSteps(std::vector<const StageInfo*> steps, ParamOverrides params) {
  for (size_t i = 0; i < steps.size(); ++i) {
    const StageInfo& step = *steps[i];
    if (Holds(steps, i, step.name)) {
      return absl::FailedPreconditionError(
          absl::StrCat("plan step ", i, " '", step.name, "' is listed twice"));
    }
    if (!step.prerequisites) continue;
    for (const std::string& need : step.prerequisites(params)) {
      if (!Holds(steps, i, need)) {
        return absl::FailedPreconditionError(
            absl::StrCat("plan step ", i, " '", step.name, "' needs step '", need,
                         "' before it, and the plan does not run it there"));
      }
    }
  }
  return Plan(std::move(steps), std::move(params));
}

}  // namespace scanprep
