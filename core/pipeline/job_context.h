// SPDX-License-Identifier: Apache-2.0
// The per-job context every stage works in: the cloud, the parameters (each use recorded in the
// report), shared neighbourhoods and measures, progress, and the plan the stages run in.
#pragma once

#include <atomic>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/pipeline/cancel.h"
#include "core/pipeline/params.h"
#include "core/pipeline/progress.h"
#include "core/pipeline/report.h"
#include "core/pipeline/stage.h"
#include "core/pipeline/warning.h"
#include "core/point_cloud.h"
#include "core/point_measures.h"
#include "core/spatial/duplicates.h"
#include "core/spatial/neighbourhoods.h"

namespace scanprep {

class JobContext : private WorkMeter {
 public:
  JobContext(PointCloud& cloud, const ParamOverrides& overrides, const CancelToken& cancel,
             ProgressFn progress);

  PointCloud& cloud() { return cloud_; }
  // The job's token, which also meters the stages' loops for progress.
  const CancelToken& cancel() const { return cancel_; }
  PointMeasures& measures() { return measures_; }

  // The value to use for a numeric parameter: the request's override if there is one, else the
  // default its spec declares. Either way it is recorded in the running stage's report.
  // Overrides were range-checked before the job started (ValidateOverrides).
  double Number(std::string_view name);
  // Like Number() for a parameter whose default is derived from the data: `derived`.
  double Number(std::string_view name, double derived);
  // Like Number() for an integer parameter.
  int64_t Integer(std::string_view name);
  int64_t Integer(std::string_view name, int64_t derived);
  // The request's override of a numeric parameter, if any, without recording it; for parameters
  // that are derived per scan and recorded under per-scan names.
  std::optional<double> Overridden(std::string_view name) const;
  // The chosen value of a choice parameter (override, else the spec's default); recorded in the
  // running stage's report as a text parameter.
  std::string Choice(std::string_view name);
  // Records a derived value that cannot be overridden (e.g. a count or a measured statistic).
  void Record(std::string_view name, double value);
  // Records a value derived for scan `scan` as `name.scanN`, or as `name` when the job has one
  // scan.
  void RecordForScan(std::string_view name, size_t scan, double value);
  // A warning with its code and the numbers behind it (docs/api.md lists the codes).
  void Warn(WarningCode code, std::string message, std::map<std::string, std::string> params = {});
  // The codes that fail the job: RunStage() then fails the stage that warned one.
  void FailOn(std::set<WarningCode> codes) { fail_on_ = std::move(codes); }
  // A radius from scanner metadata or an override (`what` names it), held to at most `limit`, a
  // multiple of the data's own scale r_g: a radius far beyond it makes every ball hold a large
  // part of the cloud. A cap is counted in the running stage's report as <stage>.radii_capped;
  // the stage's first is warned about, naming the likely causes.
  double CapRadius(std::string_view what, double radius, double limit);
  // The running stage has done at least `fraction` of its work (loops are metered anyway; this is
  // for stages whose work the meter cannot see, e.g. sequential passes).
  void Progress(double fraction);
  // The running stage will work through `items` loop items instead of work_per_point × n (for
  // work that depends on parameters, e.g. iterations).
  void ExpectWork(double items);
  // The value a numeric or choice parameter will have (override, else default), not recorded;
  // for planning before any stage runs.
  double PlannedNumber(std::string_view name) const;
  std::string PlannedChoice(std::string_view name) const;

  // Shared neighbourhoods, built on first use and reused by every later stage.
  absl::StatusOr<const Neighbourhoods*> neighbourhoods();
  // A stage that moved points by at most `max_shift` each calls this so the shared
  // neighbourhoods follow them (Neighbourhoods::PointsMoved) instead of being rebuilt.
  absl::Status PointsMoved(float max_shift);
  // Used by the "neighbourhoods" stage only.
  void SetNeighbourhoods(std::unique_ptr<Neighbourhoods> nb) { neighbourhoods_ = std::move(nb); }

  // Runs the named stage, its prerequisites first, unless they already ran in this job: for a
  // need that arises mid-stage (LoOP's surface test wants normals fitted after its removals) and
  // for running a stage outside a pipeline (tests).
  absl::Status Require(std::string_view stage);
  bool HasRun(std::string_view stage) const;

  // The job's exact duplicates, collapsed before the first stage: the stages see one point per
  // group, and the report counts every input point of a group.
  void SetDuplicates(const DuplicateGroups* duplicates) { duplicates_ = duplicates; }
  size_t duplicates_collapsed() const { return duplicates_ ? duplicates_->collapsed() : 0; }

  // The requested stages with their prerequisites first, each once, in execution order.
  std::vector<const StageInfo*> Order(const std::vector<std::string>& requested) const;
  // Order(requested), kept as the job's plan for the progress events' stage_index and
  // job_fraction.
  std::vector<const StageInfo*> Plan(const std::vector<std::string>& requested);
  // Runs one stage with timing, counts and its own report entry.
  absl::Status RunStage(const StageInfo& info);
  PipelineReport& report() { return report_; }

 private:
  StageReport& current() { return report_.stages[current_stage_]; }
  void Worked(size_t items) override;
  // Sends a progress event when the running stage's fraction passed the next 2 % step.
  void Emit(double stage_fraction);
  // Records and warns about the balls the running stage capped (Neighbourhoods::Within).
  void RecordCappedBalls(const std::string& stage);
  // Unremoved input points, each duplicate group counted with its multiplicity.
  uint64_t KeptInputPoints() const;
  // Record()s a parameter's value and returns it.
  double Recorded(std::string_view name, double value);
  static const ParamSpec& DeclaredSpec(std::string_view name, ParamKind kind, bool derived);

  PointCloud& cloud_;
  const ParamOverrides& overrides_;
  CancelToken cancel_;  // the caller's, metered by this context
  ProgressFn progress_;
  // Progress of the running stage: loop items done and expected, the last 2 % step sent.
  struct Meter {
    std::atomic<uint64_t> done{0};
    double expected = 1;
    std::atomic<int> step{-1};
  };
  Meter meter_;
  std::mutex progress_mu_;
  std::vector<const StageInfo*> plan_;
  double plan_weight_ = 0, done_weight_ = 0;  // of the plan's stages: all, and those finished
  double job_fraction_ = 0;
  size_t plan_index_ = 0;
  const DuplicateGroups* duplicates_ = nullptr;
  uint64_t capped_reported_ = 0, cut_reported_ = 0;  // Neighbourhoods' cap counters, reported
  PointMeasures measures_;
  std::unique_ptr<Neighbourhoods> neighbourhoods_;
  std::vector<std::string> completed_;
  PipelineReport report_;
  std::set<WarningCode> fail_on_;
  size_t current_stage_ = 0;
  bool running_ = false;  // a stage is running, so a RunStage() now is nested in it
};

}  // namespace scanprep
