// SPDX-License-Identifier: Apache-2.0
// Runs a plan's stages in order, and nothing else: it owns their shared state (neighbourhoods,
// measures), progress (loops metered into 2 % ticks and a job fraction weighted by the stages'
// typical cost), timing and the report, one entry per stage in plan order.
#pragma once

#include <atomic>
#include <cstdint>
#include <mutex>
#include <set>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "core/base/cancel.h"
#include "core/base/point_cloud.h"
#include "core/pipeline/plan.h"
#include "core/pipeline/progress.h"
#include "core/stages/report.h"
#include "core/stages/stage_context.h"
#include "core/stages/warning.h"

namespace scanprep {

class PipelineRunner : private WorkMeter, private StageMeter {
 public:
  // `plan`, `cloud`, `cancel` and `duplicates` (the job's collapsed duplicates, or null) must
  // outlive the runner. A stage that warns one of `fail_on` fails the job at its end.
  PipelineRunner(const Plan& plan, PointCloud& cloud, const CancelToken& cancel,
                 ProgressFn progress, std::set<WarningCode> fail_on = {},
                 const DuplicateGroups* duplicates = nullptr);

  // Runs the plan's stages not yet run, in order; stops at the first that fails.
  absl::Status Run();
  // Runs the plan's next stages, in order, up to and including `stage`, and pauses there (for tests
  // that look at a stage's inputs); INVALID_ARGUMENT if `stage` is not among them.
  absl::Status RunThrough(std::string_view stage);

  PipelineReport& report() { return report_; }
  // What the stages built (for tests that check a stage's inputs, or call a stage function with
  // them).
  SharedState& shared() { return shared_; }

 private:
  absl::Status RunStage(size_t index);
  void Worked(size_t items) override;
  void Progress(double fraction) override;
  void ExpectWork(double items) override;
  // Sends a progress event when the running stage's fraction passed the next 2 % tick.
  void Emit(double stage_fraction);
  // Records and warns about the balls the stage capped (Neighbourhoods::Within).
  void RecordBallCounts(StageReport& stage);
  // Unremoved input points, each duplicate group counted with its multiplicity.
  uint64_t KeptInputPoints() const;

  const Plan& plan_;
  PointCloud& cloud_;
  CancelToken cancel_;  // the caller's, metered by this runner
  ProgressFn progress_;
  std::set<WarningCode> fail_on_;
  SharedState shared_;
  PipelineReport report_;
  // Progress of the running stage: loop items done and expected, the last 2 % tick sent.
  struct Meter {
    std::atomic<uint64_t> done{0};
    double expected = 1;
    std::atomic<int> tick{-1};
  };
  Meter meter_;
  std::mutex progress_mu_;
  size_t next_ = 0;                           // the first stage not yet run
  size_t index_ = 0;                          // of the running stage in the plan
  double plan_weight_ = 0, done_weight_ = 0;  // of the plan's stages: all, and those finished
  double job_fraction_ = 0;
  // Neighbourhoods' ball counters, reported
  uint64_t capped_reported_ = 0, cut_reported_ = 0, sampled_reported_ = 0;
};

}  // namespace scanprep
