// SPDX-License-Identifier: Apache-2.0
#include "client/progress_view.h"

#include <cmath>
#include <cstdint>
#include <map>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace scanprep::client {

namespace v1 = ::scanprep::v1;

void ProgressView::Update(const v1::Progress& p) {
  if (!live_) return;
  std::string line;
  switch (p.phase()) {
    case v1::Progress::PHASE_UPLOAD:
      line = absl::StrFormat("upload     %3.0f%%  %d points", 100 * p.fraction(), p.points());
      break;
    case v1::Progress::PHASE_PROCESSING:
      line = absl::StrFormat("processing %3.0f%%  %s", 100 * p.fraction(), p.stage());
      break;
    case v1::Progress::PHASE_DOWNLOAD:
      line = absl::StrFormat("download   %3.0f%%  %d points", 100 * p.fraction(), p.points());
      break;
    default:
      return;
  }
  std::lock_guard lock(mu_);
  out_ << "\r\033[K" << line << std::flush;
  drawn_ = true;
}

void ProgressView::Done() {
  std::lock_guard lock(mu_);
  if (drawn_) out_ << "\r\033[K" << std::flush;
  drawn_ = false;
}

// Counts as plain integers (30462, not 3.046e+04); other values to 4 significant digits.
std::string ParameterText(double value) {
  if (value == std::trunc(value) && std::abs(value) < 1e15) {
    return absl::StrFormat("%d", static_cast<int64_t>(value));
  }
  return absl::StrFormat("%.4g", value);
}

void PrintSummary(std::ostream& out, const v1::Report& report) {
  out << absl::StrFormat("%-16s %10s %10s %9s  %s\n", "stage", "in", "out", "seconds",
                         "parameters");
  for (const v1::StageReport& stage : report.stages()) {
    // Sorted for a stable display; per-scan values ("<name>.scanN") only counted.
    std::map<std::string, double> params(stage.parameters().begin(), stage.parameters().end());
    std::string shown;
    int per_scan = 0;
    for (const auto& [name, value] : params) {
      if (absl::StrContains(name, ".scan")) {
        ++per_scan;
        continue;
      }
      absl::StrAppend(&shown, shown.empty() ? "" : " ", name, "=", ParameterText(value));
    }
    for (const auto& [name, value] : std::map<std::string, std::string>(
             stage.text_parameters().begin(), stage.text_parameters().end())) {
      absl::StrAppend(&shown, shown.empty() ? "" : " ", name, "=", value);
    }
    if (per_scan > 0) absl::StrAppendFormat(&shown, " (+%d per-scan values)", per_scan);
    std::string seconds = absl::StrFormat("%.3f", stage.seconds());
    if (stage.budget_seconds() > 0 && !stage.budget_met()) seconds += "!";
    out << absl::StrFormat("%-16s %10d %10d %9s  %s\n", stage.name(), stage.points_in(),
                           stage.points_out(), seconds, shown);
  }
  out << absl::StrFormat("points: %d received, %d invalid (NaN/Inf), %d processed, %d returned\n",
                         report.points_received(), report.points_invalid(),
                         report.points_processed(), report.points_returned());
  if (report.budget_seconds() > 0) {
    out << absl::StrFormat("time: %.3f s of a %.3f s budget (%s)\n", report.processing_seconds(),
                           report.budget_seconds(), report.budget_met() ? "met" : "MISSED");
  } else {
    out << absl::StrFormat("time: %.3f s (no budget)\n", report.processing_seconds());
  }
  for (const std::string& w : report.warnings()) out << "warning: " << w << "\n";
}

void PrintPhases(std::ostream& out, const PhaseSeconds& p) {
  const double other = p.total - p.read - p.upload - p.processing - p.download - p.write;
  out << absl::StrFormat(
      "phases: read %.3f s, upload %.3f s, processing %.3f s (server), download %.3f s, write "
      "%.3f s; total %.3f s wall (%.3f s in none of them)\n",
      p.read, p.upload, p.processing, p.download, p.write, p.total, other);
}

}  // namespace scanprep::client
