// SPDX-License-Identifier: Apache-2.0
// The server's default time budgets (seconds), from --stage_budgets ("outliers=0.2,smoothing=0.5")
// and --budget_config FILE (lines "stage seconds"; "total seconds" for the whole pipeline; '#'
// starts a comment). A job's own budget replaces these per entry.
#pragma once

#include <map>
#include <string>
#include <string_view>

#include "absl/status/statusor.h"

namespace scanprep::server {

struct TimeBudgetDefaults {
  double total_seconds = 0;                     // 0 = none
  std::map<std::string, double> stage_seconds;  // by stage name
};

// "stage=seconds,..." into `defaults.stage_seconds` (entries replace earlier ones).
absl::Status ParseStageBudgets(std::string_view spec, TimeBudgetDefaults& defaults);
// The text of a budget config file; `source` names it in errors.
absl::Status ParseBudgetConfig(std::string_view text, std::string_view source,
                               TimeBudgetDefaults& defaults);
absl::Status ReadBudgetConfig(const std::string& path, TimeBudgetDefaults& defaults);

}  // namespace scanprep::server
