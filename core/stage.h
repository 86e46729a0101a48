// SPDX-License-Identifier: Apache-2.0
// The stage interface and the per-job context every stage works in.
#pragma once

#include <cstdint>
#include <atomic>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "core/cancel.h"
#include "core/duplicates.h"
#include "core/neighbourhoods.h"
#include "core/params.h"
#include "core/point_cloud.h"
#include "core/report.h"

namespace scanprep {

// Where a running job is: its stage, that stage's place in the plan (execution order) and
// progress, and the whole job's progress (the plan's stages weighted by their typical cost).
struct ProgressEvent {
  std::string_view stage;
  size_t stage_index = 0;  // in the plan, 0-based
  size_t stage_count = 0;  // stages in the plan
  double stage_fraction = 0;  // in [0,1]; non-decreasing within a stage
  double job_fraction = 0;    // in [0,1]; non-decreasing within a job
};
// Called from any thread, serialised; at most once per 2 % of a stage.
using ProgressFn = std::function<void(const ProgressEvent&)>;

class JobContext;

class Stage {
 public:
  virtual ~Stage() = default;
  virtual absl::Status Run(JobContext& ctx) = 0;
};

struct StageInfo {
  std::string name;
  std::string summary;
  std::vector<ParamSpec> params;
  std::function<std::unique_ptr<Stage>()> make;
  // The stages this one needs run before it with the job's parameters (the plan puts them
  // first, so progress and the report follow execution order); empty = none.
  std::function<std::vector<std::string>(const JobContext&)> prerequisites;
  // Progress: the parallel-loop items the stage meters per point, and its typical cost, which
  // weights the job fraction: both measured on the 1 M-point two-scan simulated job (`scanprep
  // simulate`, default pipeline, 2 threads; cost_weight = the stage's seconds there).
  double work_per_point = 1;
  double cost_weight = 1;
};

// Every stage the service offers, in the paper's execution order.
const std::vector<StageInfo>& StageRegistry();
const StageInfo* FindStage(std::string_view name);
// All parameter specs of all stages (plus the shared neighbourhood ones).
std::vector<ParamSpec> AllParamSpecs();
const ParamSpec* FindParam(std::string_view name);

// Per-point measures shared between stages (§8, §9), filled by the "measures" stage.
struct PointMeasures {
  std::vector<float> quality;    // q̂ in [0,1], 1 = frontal view
  std::vector<float> curvature;  // κ̂ in [0,1], 1 = significant edge
  std::vector<float> surface_variation;  // σ = λ0/(λ0+λ1+λ2), from the normals stage
  std::vector<float> fit_rms;            // √λ0 (mm): RMS offset of the normal fit from its plane
};

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
  // Records a value derived for scan `scan` as `name.scanN`, or as `name` when the job has one scan.
  void RecordForScan(std::string_view name, size_t scan, double value);
  void Warn(std::string message);
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

  // Runs the named stage unless it already ran in this job; how stages get the normals or
  // measures they depend on without the caller listing them.
  absl::Status Require(std::string_view stage);
  bool HasRun(std::string_view stage) const;

  // The job's exact duplicates, collapsed before the first stage: the stages see one point per
  // group, and the report counts every input point of a group.
  void SetDuplicates(const DuplicateGroups* duplicates) { duplicates_ = duplicates; }
  size_t duplicates_collapsed() const { return duplicates_ ? duplicates_->collapsed() : 0; }

  // The requested stages with their prerequisites first, each once, in execution order; kept
  // for the progress events' stage_index and job_fraction.
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
  size_t current_stage_ = 0;
  bool running_ = false;  // a stage is running, so a RunStage() now is nested in it
};

}  // namespace scanprep
