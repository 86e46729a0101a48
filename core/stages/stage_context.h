// SPDX-License-Identifier: Apache-2.0
// What a stage works with, and nothing more: the job's cloud, the shared neighbourhoods and
// measures, the cancel token, its settings (each parameter used recorded in its report entry),
// warnings and progress. It cannot run another stage: the plan orders them and the runner runs
// them.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/base/cancel.h"
#include "core/base/point_cloud.h"
#include "core/base/point_measures.h"
#include "core/spatial/duplicates.h"
#include "core/spatial/neighbourhoods.h"
#include "core/stages/param_table.h"
#include "core/stages/report.h"
#include "core/stages/warning.h"

namespace scanprep {

// What the plan's stages build for the ones after them; the runner owns it for the job.
struct SharedState {
  PointMeasures measures;
  // Built by the "neighbourhoods" stage, which the plan puts before every stage that needs them.
  std::unique_ptr<Neighbourhoods> neighbourhoods;
  // The job's exact duplicates, collapsed before the first stage: the stages see one point per
  // group, and the report counts every input point of a group. Null: none.
  const DuplicateGroups* duplicates = nullptr;
  // The stages that ran to their end so far, in order (a stage whose figures depend on an earlier
  // one, e.g. health's merged share on correction, asks StageContext::Ran).
  std::vector<std::string_view> stages_run;
  // Set by the "health" stage; the runner moves it into PipelineReport::health.
  std::optional<HealthReport> health;
};

// The running stage's progress, kept by the runner.
class StageMeter {
 public:
  virtual ~StageMeter() = default;
  virtual void Progress(double fraction) = 0;
  virtual void ExpectWork(double items) = 0;
};

class StageContext {
 public:
  StageContext(PointCloud& cloud, SharedState& shared, const ParamOverrides& overrides,
               const CancelToken& cancel, StageMeter& meter, StageReport& report,
               std::vector<Warning>& warnings)
      : cloud_(cloud),
        shared_(shared),
        overrides_(overrides),
        cancel_(cancel),
        meter_(meter),
        report_(report),
        warnings_(warnings) {}

  PointCloud& cloud() { return cloud_; }
  // The job's token, which also meters the stages' loops for progress.
  const CancelToken& cancel() const { return cancel_; }
  PointMeasures& measures() { return shared_.measures; }

  // The stage's settings from its table: each parameter's override, else its default, recorded
  // in the stage's report (derived ones are the stage's to record, with the value it derives).
  template <typename S>
  S Settings(const ParamTable<S>& table) {
    S settings = table.Read(overrides_);
    table.Record(overrides_, settings, report_);
    return settings;
  }
  // The same, recording only `fields`: for an internal stage that carries on its offered stage's
  // work with some of its parameters.
  template <typename S, typename... T>
  S SettingsUsing(const ParamTable<S>& table, T S::*... fields) {
    S settings = table.Read(overrides_);
    table.Record(overrides_, settings, report_, {table.Name(fields)...});
    return settings;
  }
  // Records a derived value that cannot be overridden (e.g. a count or a measured statistic).
  void Record(std::string_view name, double value);
  // Records a value derived for scan `scan` as `name.scanN`, or as `name` when the job has one
  // scan.
  void RecordForScan(std::string_view name, size_t scan, double value);
  // A warning with its code and the numbers behind it (docs/api.md lists the codes).
  void Warn(WarningCode code, std::string message, std::map<std::string, std::string> params = {});
  // A radius from scanner metadata or an override (`what` names it), held to at most `limit`, a
  // multiple of the data's own scale r_g: a radius far beyond it makes every ball hold a large
  // part of the cloud. A cap is counted in the stage's report as <stage>.radii_capped; the
  // stage's first is warned about, naming the likely causes.
  double CapRadius(std::string_view what, double radius, double limit);
  // The stage has done at least `fraction` of its work (loops are metered anyway; this is for
  // stages whose work the meter cannot see, e.g. sequential passes).
  void Progress(double fraction) { meter_.Progress(fraction); }
  // The stage will work through `items` loop items instead of work_per_point × n (for work that
  // depends on parameters, e.g. iterations).
  void ExpectWork(double items) { meter_.ExpectWork(items); }

  // The shared neighbourhoods. The plan puts the "neighbourhoods" stage before every stage that
  // asks (Plan refuses one that does not), so the error is a programming error's backstop.
  absl::StatusOr<const Neighbourhoods*> neighbourhoods() const;
  // A stage that moved points by at most `max_shift` each calls this so the shared
  // neighbourhoods follow them (Neighbourhoods::PointsMoved) instead of being rebuilt.
  absl::Status PointsMoved(float max_shift);
  // Used by the "neighbourhoods" stage only.
  void SetNeighbourhoods(std::unique_ptr<Neighbourhoods> nb) {
    shared_.neighbourhoods = std::move(nb);
  }
  // Whether stage `name` ran (to its end) before this one.
  bool Ran(std::string_view name) const;
  // The job's health report (the "health" stage's result).
  void SetHealth(HealthReport health) { shared_.health = std::move(health); }
  size_t duplicates_collapsed() const {
    return shared_.duplicates ? shared_.duplicates->collapsed() : 0;
  }

 private:
  PointCloud& cloud_;
  SharedState& shared_;
  const ParamOverrides& overrides_;
  const CancelToken& cancel_;
  StageMeter& meter_;
  StageReport& report_;
  std::vector<Warning>& warnings_;
};

}  // namespace scanprep
