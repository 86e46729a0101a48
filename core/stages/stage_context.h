// SPDX-License-Identifier: Apache-2.0
// What the runner hands a stage's adapter (the Stage::Run that calls the stage function): the
// job's cloud, the shared neighbourhoods and measures, its settings (each parameter used recorded
// in its report entry) and its reporter. It cannot run another stage: the plan orders them and the
// runner runs them.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
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
#include "core/stages/stage_reporter.h"
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
  // The pairs' misalignment as the "registration" stage found it before it moved the scans; the
  // "health" stage reports these, so a sensor's drift stays visible after registration.
  std::optional<std::vector<PairHealth>> pairs_before_registration;
  // Set by the "registration" stage; the runner moves it into PipelineReport::registration.
  std::vector<ScanRegistration> registration;
};

class StageContext {
 public:
  StageContext(PointCloud& cloud, SharedState& shared, const ParamOverrides& overrides,
               const CancelToken& cancel, StageMeter& meter, StageReport& report,
               std::vector<Warning>& warnings)
      : cloud_(cloud),
        shared_(shared),
        overrides_(overrides),
        report_(report),
        out_(report, warnings, cancel, cloud.scans.size(), &meter) {}

  PointCloud& cloud() { return cloud_; }
  // What the stage records, warns and meters through, with the job's cancel token.
  StageReporter& out() { return out_; }
  PointMeasures& measures() { return shared_.measures; }

  // The stage's settings from its table: each parameter's override, else its default, recorded
  // in the stage's report (derived ones are the stage's to record, with the value it derives).
  template <typename S>
  S Settings(const ParamTable<S>& table) {
    S settings = table.Read(overrides_);
    RecordSettings(table, settings);
    return settings;
  }
  // Records `settings`, read from `table`, in the stage's report: for a stage that records its
  // parameters only when it used them.
  template <typename S>
  void RecordSettings(const ParamTable<S>& table, const S& settings) {
    table.Record(overrides_, settings, report_);
  }
  const ParamOverrides& overrides() const { return overrides_; }
  // The same, recording only `fields`: for an internal stage that carries on its offered stage's
  // work with some of its parameters.
  template <typename S, typename... T>
  S SettingsUsing(const ParamTable<S>& table, T S::*... fields) {
    S settings = table.Read(overrides_);
    table.Record(overrides_, settings, report_, {table.Name(fields)...});
    return settings;
  }
  // The shared neighbourhoods. The plan puts the "neighbourhoods" stage before every stage that
  // asks (Plan refuses one that does not), so the error is a programming error's backstop.
  absl::StatusOr<Neighbourhoods*> neighbourhoods() const;
  // Used by the "neighbourhoods" stage only.
  void SetNeighbourhoods(std::unique_ptr<Neighbourhoods> nb) {
    shared_.neighbourhoods = std::move(nb);
  }
  // Whether stage `name` ran (to its end) before this one.
  bool Ran(std::string_view name) const;
  // The job's health report (the "health" stage's result).
  void SetHealth(HealthReport health) { shared_.health = std::move(health); }
  void SetRegistration(std::vector<PairHealth> pairs_before, std::vector<ScanRegistration> scans) {
    shared_.pairs_before_registration = std::move(pairs_before);
    shared_.registration = std::move(scans);
  }
  std::optional<std::vector<PairHealth>> TakePairsBeforeRegistration() {
    return std::exchange(shared_.pairs_before_registration, std::nullopt);
  }
  size_t duplicates_collapsed() const {
    return shared_.duplicates ? shared_.duplicates->collapsed() : 0;
  }

 private:
  PointCloud& cloud_;
  SharedState& shared_;
  const ParamOverrides& overrides_;
  StageReport& report_;
  StageReporter out_;
};

}  // namespace scanprep
