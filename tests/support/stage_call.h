// SPDX-License-Identifier: Apache-2.0
// A stage's unit tests call the stage function itself: the stages its plan puts before it build
// its inputs (through the runner, as a job would), then the test calls the function with them,
// its typed settings and a reporter of its own. No runner, plan or context is involved in the
// call under test.
#pragma once

#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "absl/status/statusor.h"
#include "core/base/status_macros.h"
#include "core/stages/param_table.h"
#include "core/stages/params.h"
#include "core/stages/stage.h"
#include "core/stages/stage_reporter.h"
#include "tests/support/planned_stages.h"

namespace scanprep::testing {

// What the stage function is called with.
struct StageInputs {
  PointCloud& cloud;
  PointMeasures& measures;
  Neighbourhoods& neighbourhoods;
  const ParamOverrides& params;
  StageReport& entry;
  StageReporter& out;

  // The stage's settings from its table and `params`, recorded in its entry as the runner's
  // adapter records them.
  template <typename S>
  S Settings(const ParamTable<S>& table) {
    S settings = table.Read(params);
    table.Record(params, settings, entry);
    return settings;
  }
};

// Plans `stages` (default: `stage` alone) with `params` (refused as a job's would be), runs the
// plan's stages before `stage`, then `call(inputs)`. The report holds the earlier stages' entries
// and warnings, then the called stage's entry (its name, points in and out, what it recorded) and
// warnings.
template <typename Call>
absl::StatusOr<PipelineReport> CallStage(PointCloud& cloud, std::string_view stage,
                                         const ParamOverrides& params, Call call,
                                         std::vector<std::string> stages = {}) {
  SCANPREP_RETURN_IF_ERROR(ValidateOverrides(params, AllParamSpecs()));
  if (cloud.flags.size() != cloud.size()) cloud.FinishLoading();
  if (stages.empty()) stages = {std::string(stage)};
  PlannedStages before(cloud, stages, params);
  SCANPREP_RETURN_IF_ERROR(before.RunBefore(stage));
  PipelineReport report = std::move(before.report());
  StageReport entry{.name = std::string(stage), .points_in = cloud.CountKept()};
  CancelToken cancel;
  StageReporter out(entry, report.warnings, cancel, cloud.scans.size());
  StageInputs inputs{cloud, before.measures(), before.neighbourhoods(), params, entry, out};
  SCANPREP_RETURN_IF_ERROR(call(inputs));
  entry.points_out = cloud.CountKept();
  report.stages.push_back(std::move(entry));
  return report;
}

}  // namespace scanprep::testing
