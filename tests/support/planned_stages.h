// SPDX-License-Identifier: Apache-2.0
// Stages run outside RunPipeline, as a job plans them (prerequisites first, each once), for tests
// that look at what the stages built (measures, neighbourhoods) or call a stage function with them.
#pragma once

#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "core/pipeline/pipeline_runner.h"
#include "core/pipeline/plan.h"

namespace scanprep::testing {

class PlannedStages {
 public:
  // Plans `stages` with `params`; `cloud` must outlive this.
  PlannedStages(PointCloud& cloud, const std::vector<std::string>& stages,
                const ParamOverrides& params = {})
      : plan_(Plan::Resolve(stages, params)) {
    if (plan_.ok())
      runner_ = std::make_unique<PipelineRunner>(*plan_, cloud, cancel_, ProgressFn{});
  }
  // The runner refers to the plan and the token held here: not to be copied or moved.
  PlannedStages(const PlannedStages&) = delete;
  PlannedStages& operator=(const PlannedStages&) = delete;

  // Runs the rest of the plan (PipelineRunner::Run).
  absl::Status Run() { return plan_.ok() ? runner_->Run() : plan_.status(); }
  // Runs the plan up to and including `stage` (PipelineRunner::RunThrough).
  absl::Status RunThrough(std::string_view stage) {
    return plan_.ok() ? runner_->RunThrough(stage) : plan_.status();
  }

  // Runs the plan's stages before `stage` (none when it is the first).
  absl::Status RunBefore(std::string_view stage) {
    if (!plan_.ok()) return plan_.status();
    const auto& stages = plan_->stages();
    for (size_t i = 1; i < stages.size(); ++i) {
      if (stages[i]->name == stage) return runner_->RunThrough(stages[i - 1]->name);
    }
    return absl::OkStatus();
  }

  // Only after a run that built them.
  PointMeasures& measures() { return runner_->shared().measures; }
  Neighbourhoods& neighbourhoods() { return *runner_->shared().neighbourhoods; }
  PipelineReport& report() { return runner_->report(); }

 private:
  CancelToken cancel_;
  absl::StatusOr<Plan> plan_;
  std::unique_ptr<PipelineRunner> runner_;
};

}  // namespace scanprep::testing
