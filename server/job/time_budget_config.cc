// SPDX-License-Identifier: Apache-2.0
#include "server/job/time_budget_config.h"

#include <cmath>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "core/base/did_you_mean.h"
#include "core/base/status_macros.h"
#include "core/io/read_file.h"
#include "core/stages/stage.h"

namespace scanprep::server {
namespace {

// Abseil's string_view is not std::string_view here: entries travel as std::string.
absl::StatusOr<double> ParseSeconds(const std::string& text, const std::string& where) {
  double seconds = 0;
  if (!absl::SimpleAtod(text, &seconds) || !std::isfinite(seconds) || seconds < 0) {
    return absl::InvalidArgumentError(
        absl::StrCat(where, ": '", text, "' is not a number of seconds >= 0"));
  }
  return seconds;
}

// One "stage seconds" entry; "total" sets the whole-pipeline budget when `allow_total`.
absl::Status AddEntry(const std::string& name, const std::string& value, const std::string& where,
                      bool allow_total, TimeBudgetDefaults& defaults) {
  SCANPREP_ASSIGN_OR_RETURN(auto seconds, ParseSeconds(value, where));
  if (allow_total && name == "total") {
    defaults.total_seconds = seconds;
    return absl::OkStatus();
  }
  if (FindOfferedStage(name) == nullptr) {
    const std::vector<std::string> known = StageNames();
    return absl::InvalidArgumentError(absl::StrCat(where, ": unknown stage '", name, "'",
                                                   DidYouMean(name, known),
                                                   " (known: ", absl::StrJoin(known, ", "), ")"));
  }
  defaults.stage_seconds[name] = seconds;
  return absl::OkStatus();
}

}  // namespace

absl::Status ParseStageBudgets(std::string_view spec, TimeBudgetDefaults& defaults) {
  for (absl::string_view entry :
       absl::StrSplit(absl::string_view(spec.data(), spec.size()), ',', absl::SkipWhitespace())) {
    const std::vector<std::string> kv = absl::StrSplit(entry, absl::MaxSplits('=', 1));
    const std::string where = absl::StrCat("--stage_budgets entry '", entry, "'");
    if (kv.size() != 2) {
      return absl::InvalidArgumentError(absl::StrCat(where, ": expected stage=seconds"));
    }
    SCANPREP_RETURN_IF_ERROR(AddEntry(std::string(absl::StripAsciiWhitespace(kv[0])),
                                      std::string(absl::StripAsciiWhitespace(kv[1])), where, false,
                                      defaults));
  }
  return absl::OkStatus();
}

absl::Status ParseBudgetConfig(std::string_view text, std::string_view source,
                               TimeBudgetDefaults& defaults) {
  int line_number = 0;
  for (absl::string_view line : absl::StrSplit(absl::string_view(text.data(), text.size()), '\n')) {
    ++line_number;
    line = line.substr(0, line.find('#'));
    const std::vector<std::string> fields =
        absl::StrSplit(line, absl::ByAnyChar(" \t\r"), absl::SkipEmpty());
    if (fields.empty()) continue;
    const std::string where = absl::StrCat(std::string(source), ":", line_number);
    if (fields.size() != 2) {
      return absl::InvalidArgumentError(
          absl::StrCat(where, ": expected 'stage seconds' (or 'total seconds')"));
    }
    SCANPREP_RETURN_IF_ERROR(AddEntry(fields[0], fields[1], where, true, defaults));
  }
  return absl::OkStatus();
}

absl::Status ReadBudgetConfig(const std::string& path, TimeBudgetDefaults& defaults) {
  SCANPREP_ASSIGN_OR_RETURN(auto text, io::ReadFileToString(path));
  return ParseBudgetConfig(text, path, defaults);
}

}  // namespace scanprep::server
