// SPDX-License-Identifier: Apache-2.0
// What a pipeline run tells its caller: per-stage counts, wall time, the parameters it used.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/stages/health_report.h"
#include "core/stages/registration_report.h"
#include "core/stages/warning.h"

namespace scanprep {

struct StageReport {
  std::string name;
  uint64_t points_in = 0;   // unremoved points when the stage started
  uint64_t points_out = 0;  // unremoved points when it ended
  double seconds = 0;
  // Every parameter the stage used, derived or overridden, by its full name (lengths in mm).
  std::map<std::string, double> parameters;
  // Every choice parameter the stage used, e.g. "outliers.method" = "nn".
  std::map<std::string, std::string> text_parameters;
  double budget_seconds = 0;  // 0 = no budget
  bool budget_met = true;
};

struct PipelineReport {
  std::vector<StageReport> stages;
  double total_seconds = 0;
  double budget_seconds = 0;
  bool budget_met = true;
  // Input points within the resolution of a point of a lower-numbered scan (DuplicateGroups),
  // with a warning when they are kRepeatedScanShare of a scan (pipeline.cc).
  uint64_t points_coincident_across_scans = 0;
  std::vector<Warning> warnings;
  // Scanner health, when the plan ran the "health" stage.
  std::optional<HealthReport> health;
  // When the plan ran the "registration" stage: one per scan that overlaps another enough to be
  // measured, in scan order.
  std::vector<ScanRegistration> registration;
  // The plan's estimated work over the default plan's (core/pipeline/plan_cost.h).
  double estimated_plan_cost = 1;
};

}  // namespace scanprep
