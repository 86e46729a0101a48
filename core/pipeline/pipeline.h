// SPDX-License-Identifier: Apache-2.0
// Runs a job's stages in order on the calling thread's TBB arena.
#pragma once

#include <map>
#include <set>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "core/base/cancel.h"
#include "core/base/point_cloud.h"
#include "core/pipeline/progress.h"
#include "core/stages/params.h"
#include "core/stages/report.h"
#include "core/stages/stage.h"
#include "core/stages/warning.h"

namespace scanprep {

struct PipelineOptions {
  std::vector<std::string> stages;  // empty = DefaultStages()
  ParamOverrides params;
  double budget_seconds = 0;                           // whole pipeline; 0 = none
  std::map<std::string, double> stage_budget_seconds;  // per stage name
  // Warnings that fail the job (FAILED_PRECONDITION, FailOnWarnings) at the end of the stage
  // that raised them, before any later stage runs.
  std::set<WarningCode> fail_on;
};

// The paper's case-study order: outliers → correction → smoothing → simplification, with the
// scanner-health report (docs/health.md) between correction and smoothing, while the positions
// are still the measured ones; the plan (Plan::Resolve) runs each stage's prerequisites
// (neighbourhoods, normals, measures) first.
std::vector<std::string> DefaultStages();

// Checks stage names (known, not repeated), parameter overrides and budgets before any work.
absl::Status ValidateOptions(const PipelineOptions& options);

// Runs the stages over `cloud` (coordinates in mm). Removed points stay in the cloud, labelled in
// `cloud.flags`. Returns CANCELLED promptly when `cancel` fires.
absl::StatusOr<PipelineReport> RunPipeline(PointCloud& cloud, const PipelineOptions& options,
                                           const CancelToken& cancel, ProgressFn progress = {});

}  // namespace scanprep
