// SPDX-License-Identifier: Apache-2.0
#include "client/progress_view.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "wire/warning_codes.h"

namespace scanprep::client {

namespace v1 = ::scanprep::v1;

absl::StatusOr<ProgressMode> ParseProgressMode(const std::string& text, bool terminal) {
  if (text == "auto") return terminal ? ProgressMode::kLive : ProgressMode::kPlain;
  if (text == "live") return ProgressMode::kLive;
  if (text == "plain") return ProgressMode::kPlain;
  if (text == "off") return ProgressMode::kOff;
  return absl::InvalidArgumentError(
      absl::StrCat("--progress ", text, ": expected auto, live, plain or off"));
}

ProgressView::ProgressView(std::ostream& out, ProgressMode mode, Clock now)
    : out_(out), mode_(mode), now_(std::move(now)), start_(now_()) {}

namespace {

// The ETA needs a little progress and time to extrapolate from; before that it says so.
constexpr double kEtaMinFraction = 0.02;
constexpr absl::Duration kEtaMinTime = absl::Seconds(1);
constexpr absl::Duration kPlainHeartbeat = absl::Seconds(10);

std::string Seconds(absl::Duration d) {
  return absl::StrFormat("%.1f s", absl::ToDoubleSeconds(d));
}

}  // namespace

std::string ProgressView::Describe(const v1::Progress& p, absl::Time now) {
  switch (p.phase()) {
    case v1::Progress::PHASE_UPLOAD:
      return absl::StrFormat("upload     %3.0f%%  %d points", 100 * p.fraction(), p.points());
    case v1::Progress::PHASE_DOWNLOAD:
      return absl::StrFormat("download   %3.0f%%  %d points", 100 * p.fraction(), p.points());
    case v1::Progress::PHASE_PROCESSING: {
      if (!processing_start_) processing_start_ = now;
      // Remaining time from the job fraction so far: the stages are weighted by their typical
      // cost, so the rate is close to even across the job.
      const double f = p.job_fraction();
      const absl::Duration spent = now - *processing_start_;
      const std::string eta = f >= kEtaMinFraction && spent >= kEtaMinTime
                                  ? absl::StrCat("ETA ", Seconds(spent * ((1 - f) / f)))
                                  : std::string("ETA ...");
      return absl::StrFormat("processing %3.0f%%  %s  [%d/%d] %s %.0f%%", 100 * f, eta,
                             p.stage_index() + 1, p.stage_count(), p.stage(), 100 * p.fraction());
    }
    default:
      return "";
  }
}

// A line when the phase or stage changed, when the stage passed the next quarter, or when the
// last line is 10 s old (so a log shows the job is alive).
bool ProgressView::PlainLineDue(const v1::Progress& p, absl::Time now) {
  const std::string step = absl::StrCat(p.phase(), "/", p.stage());
  const int quarter = std::min(3, static_cast<int>(4 * p.fraction()));
  const bool due =
      step != last_step_ || quarter > last_quarter_ || now - last_line_ >= kPlainHeartbeat;
  if (due) {
    if (step != last_step_) last_quarter_ = -1;
    last_step_ = step;
    last_quarter_ = std::max(last_quarter_, quarter);
    last_line_ = now;
  }
  return due;
}

void ProgressView::Update(const v1::Progress& p) {
  if (mode_ == ProgressMode::kOff) return;
  std::lock_guard lock(mu_);
  const absl::Time now = now_();
  const std::string text = Describe(p, now);
  if (text.empty()) return;
  const std::string elapsed = Seconds(now - start_);
  if (mode_ == ProgressMode::kLive) {
    out_ << "\r\033[K" << text << "  elapsed " << elapsed << std::flush;
    drawn_ = true;
  } else if (PlainLineDue(p, now)) {
    out_ << absl::StrFormat("[%8s] ", elapsed) << text << "\n" << std::flush;
  }
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
  PrintWarnings(out, report);
}

void PrintWarnings(std::ostream& out, const v1::Report& report) {
  // With its code, for a reader who will gate on it (--fail_on); a server that predates the codes
  // sends the text alone.
  if (report.warning_details_size() == report.warnings_size()) {
    for (const v1::Warning& w : report.warning_details()) {
      std::string_view code = v1::WarningCode_Name(w.code());  // empty for a newer code
      if (code.starts_with(kProtoWarningCodePrefix))
        code.remove_prefix(kProtoWarningCodePrefix.size());
      out << "warning " << (code.empty() ? absl::StrCat(w.code()) : std::string(code)) << ": "
          << w.message() << "\n";
    }
  } else {
    for (const std::string& w : report.warnings()) out << "warning: " << w << "\n";
  }
}

void PrintPhases(std::ostream& out, const PhaseSeconds& p) {
  const double other = p.total - p.read - p.upload - p.processing - p.download - p.write;
  out << absl::StrFormat(
      "phases: read %.3f s, upload %.3f s, processing %.3f s (server), download %.3f s, write "
      "%.3f s; total %.3f s wall (%.3f s in none of them)\n",
      p.read, p.upload, p.processing, p.download, p.write, p.total, other);
}

}  // namespace scanprep::client
