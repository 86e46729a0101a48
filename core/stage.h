// SPDX-License-Identifier: Apache-2.0
// The stage interface and the per-job context every stage works in.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
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

// Called with the running stage's name and its progress in [0,1]; may be called from any thread.
using ProgressFn = std::function<void(std::string_view stage, double fraction)>;

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

class JobContext {
 public:
  JobContext(PointCloud& cloud, const ParamOverrides& overrides, const CancelToken& cancel,
             ProgressFn progress);

  PointCloud& cloud() { return cloud_; }
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
  void Progress(double fraction) const;

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

  // Runs one stage with timing, counts and its own report entry.
  absl::Status RunStage(const StageInfo& info);
  PipelineReport& report() { return report_; }

 private:
  StageReport& current() { return report_.stages[current_stage_]; }
  // Records and warns about the balls the running stage capped (Neighbourhoods::Within).
  void RecordCappedBalls(const std::string& stage);
  // Unremoved input points, each duplicate group counted with its multiplicity.
  uint64_t KeptInputPoints() const;
  // Record()s a parameter's value and returns it.
  double Recorded(std::string_view name, double value);
  static const ParamSpec& DeclaredSpec(std::string_view name, ParamKind kind, bool derived);

  PointCloud& cloud_;
  const ParamOverrides& overrides_;
  const CancelToken& cancel_;
  ProgressFn progress_;
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
