// SPDX-License-Identifier: Apache-2.0
#include "core/pipeline/pipeline.h"

#include <algorithm>
#include <chrono>
#include <optional>
#include <set>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "core/base/did_you_mean.h"
#include "core/base/field_error.h"
#include "core/base/per_scan_values.h"
#include "core/base/status_macros.h"
#include "core/pipeline/pipeline_runner.h"
#include "core/pipeline/plan.h"
#include "core/pipeline/plan_cost.h"
#include "core/spatial/duplicates.h"
#include "core/stages/stage_names.h"

namespace scanprep {

std::vector<std::string> DefaultStages() {
  using namespace stage_names;
  return List({kOutliers, kRegistration, kCorrection, kHealth, kSmoothing, kSimplification});
}

absl::Status ValidateOptions(const PipelineOptions& options) {
  std::set<std::string> seen;
  for (const std::string& name : options.stages) {
    if (FindOfferedStage(name) == nullptr) {
      const std::vector<std::string> known = StageNames();
      return FieldError("options.stages",
                        absl::StrCat("unknown stage '", name, "'", DidYouMean(name, known),
                                     " (known: ", absl::StrJoin(known, ", "), ")"));
    }
    if (!seen.insert(name).second) {
      return FieldError("options.stages", absl::StrCat("stage '", name, "' is listed twice"));
    }
  }
  for (const auto& [name, seconds] : options.stage_budget_seconds) {
    const std::string field = absl::StrCat("budget.stage_seconds['", name, "']");
    if (FindOfferedStage(name) == nullptr) {
      return FieldError(field, absl::StrCat("unknown stage", DidYouMean(name, StageNames())));
    }
    if (!(seconds >= 0)) return FieldError(field, "must be >= 0");
  }
  if (!(options.budget_seconds >= 0)) {
    return FieldError("budget.total_seconds", "must be >= 0");
  }
  return ValidateOverrides(options.params, AllParamSpecs());
}

namespace {

absl::StatusOr<PipelineReport> RunStages(const Plan& plan, PointCloud& cloud,
                                         const PipelineOptions& options, const CancelToken& cancel,
                                         ProgressFn progress, const DuplicateGroups& duplicates) {
  PipelineRunner runner(plan, cloud, cancel, std::move(progress), options.fail_on, &duplicates);
  SCANPREP_RETURN_IF_ERROR(runner.Run());
  return std::move(runner.report());
}

// SCAN_REPEATED for the first scan with at least kRepeatedScanShare of its points within the
// resolution of an earlier scan's (a scan sent twice or re-exported). Below that share they are
// chance: two independent measurements from one pose put about 1 % of their points that close
// (the simulated box at its own noise), other poses fewer.
constexpr double kRepeatedScanShare = 0.1;
std::optional<Warning> ScanRepeatedWarning(const PointCloud& cloud,
                                           const DuplicateGroups& duplicates) {
  const std::vector<size_t> points = ScanPointCounts(cloud);
  for (size_t s = 0; s < duplicates.repeated_per_scan.size(); ++s) {
    const uint64_t repeated = duplicates.repeated_per_scan[s];
    if (repeated == 0 || repeated < kRepeatedScanShare * points[s]) continue;
    const double share = double(repeated) / points[s];
    return Warning{
        WarningCode::kScanRepeated,
        absl::StrFormat("%d of scan %d's (%s) %d points (%.1f %%) lie within the sensor's "
                        "resolution of a point of an earlier scan of the job (%d in all): was a "
                        "scan sent twice, or re-exported? They are not merged: each is processed "
                        "as a point of its own scan",
                        repeated, s, cloud.scans[s].id, points[s], 100 * share,
                        duplicates.coincident_across_scans),
        {{"points", absl::StrCat(duplicates.coincident_across_scans)},
         {"scan", absl::StrCat(s)},
         {"share", absl::StrFormat("%.3f", share)}}};
  }
  return std::nullopt;
}

// Each stage's time, and the job's, against the budgets the job set (0: none).
void JudgeTimeBudgets(const PipelineOptions& options, PipelineReport& report) {
  for (StageReport& stage : report.stages) {
    auto it = options.stage_budget_seconds.find(stage.name);
    if (it == options.stage_budget_seconds.end() || it->second <= 0) continue;
    stage.budget_seconds = it->second;
    stage.budget_met = stage.seconds <= it->second;
  }
  report.budget_seconds = options.budget_seconds;
  report.budget_met = options.budget_seconds <= 0 || report.total_seconds <= options.budget_seconds;
}

}  // namespace

absl::StatusOr<PipelineReport> RunPipeline(PointCloud& cloud, const PipelineOptions& options,
                                           const CancelToken& cancel, ProgressFn progress) {
  SCANPREP_RETURN_IF_ERROR(ValidateOptions(options));
  SCANPREP_ASSIGN_OR_RETURN(
      const Plan plan,
      Plan::Resolve(options.stages.empty() ? DefaultStages() : options.stages, options.params));
  if (cloud.flags.size() != cloud.size()) cloud.FinishLoading();
  const auto start = std::chrono::steady_clock::now();
  SCANPREP_ASSIGN_OR_RETURN(DuplicateGroups duplicates, FindDuplicates(cloud, cancel));
  const size_t coincident_across_scans = duplicates.coincident_across_scans;
  std::vector<Warning> before_stages;
  if (std::optional<Warning> repeated = ScanRepeatedWarning(cloud, duplicates)) {
    before_stages.push_back(*std::move(repeated));
  }
  // Known before any stage runs, so a job that fails on it does no work.
  SCANPREP_RETURN_IF_ERROR(FailOnWarnings(before_stages, options.fail_on));
  PipelineReport report;
  if (duplicates.collapsed() == 0) {
    duplicates = {};  // the identity: 8 bytes a point the stages never read
    SCANPREP_ASSIGN_OR_RETURN(
        report, RunStages(plan, cloud, options, cancel, std::move(progress), duplicates));
  } else {
    PointCloud compact = CompactDuplicates(cloud, duplicates);
    SCANPREP_ASSIGN_OR_RETURN(
        report, RunStages(plan, compact, options, cancel, std::move(progress), duplicates));
    ExpandDuplicates(compact, duplicates, cloud);
  }
  report.points_coincident_across_scans = coincident_across_scans;
  report.estimated_plan_cost = EstimatePlanCost(plan).ratio;
  report.warnings.insert(report.warnings.end(), before_stages.begin(), before_stages.end());
  FoldRepeatedWarnings(report.warnings);
  report.total_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  JudgeTimeBudgets(options, report);
  return report;
}

}  // namespace scanprep
