// SPDX-License-Identifier: Apache-2.0
// What the CLI shows the user: progress while a job runs (live on a terminal, plain lines
// otherwise) and the end-of-job summary table.
#pragma once

#include <functional>
#include <mutex>
#include <optional>
#include <ostream>
#include <string>

#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "scanprep/v1/scanprep.pb.h"

namespace scanprep::client {

// How `scanprep process` shows progress on stderr.
enum class ProgressMode {
  kLive,   // one line redrawn in place (a terminal)
  kPlain,  // a line per step, for logs and pipes: when a phase or stage starts, at each quarter
           // of it, and at least every 10 s
  kOff,
};

// "auto" (live on a terminal, else plain), "live", "plain" or "off"; INVALID_ARGUMENT otherwise.
absl::StatusOr<ProgressMode> ParseProgressMode(const std::string& text, bool terminal);

// The job's progress for a person: the whole job's percentage, elapsed time and ETA, and the
// running stage with its place in the plan ([3/7]) and its own percentage.
class ProgressView {
 public:
  using Clock = std::function<absl::Time()>;
  ProgressView(std::ostream& out, ProgressMode mode, Clock now = absl::Now);
  // Thread-safe; called from the call's reader thread.
  void Update(const scanprep::v1::Progress& progress);
  // Clears the live line.
  void Done();

 private:
  // The text after the elapsed time, e.g. "processing  41%  ETA 5.2 s  [3/7] normals 62%".
  std::string Describe(const scanprep::v1::Progress& p, absl::Time now);
  bool PlainLineDue(const scanprep::v1::Progress& p, absl::Time now);

  std::mutex mu_;
  std::ostream& out_;
  const ProgressMode mode_;
  const Clock now_;
  const absl::Time start_;
  std::optional<absl::Time> processing_start_;
  bool drawn_ = false;
  // Plain mode: what the last line showed.
  std::string last_step_;  // phase and stage
  int last_quarter_ = -1;
  absl::Time last_line_ = absl::InfinitePast();
};

// One job's phases for `scanprep process`: read, upload, download, write and total on the
// client's clock; processing is the server's report.processing_seconds.
struct PhaseSeconds {
  double read = 0, upload = 0, processing = 0, download = 0, write = 0, total = 0;
};

// One line with every phase, and what none of them covers (connecting, the server assembling
// the job and preparing the first result chunk).
void PrintPhases(std::ostream& out, const PhaseSeconds& phases);

// A report parameter for people: counts as plain integers, other values to 4 digits.
std::string ParameterText(double value);

// Per stage: points in and out, seconds and the stage's parameters, numbers and choices (per-scan
// values are summarised by count); then point totals, invalid points, budget and warnings.
void PrintSummary(std::ostream& out, const scanprep::v1::Report& report);

// The report's warnings, one a line, each with its code (PrintSummary's last lines).
void PrintWarnings(std::ostream& out, const scanprep::v1::Report& report);

}  // namespace scanprep::client
