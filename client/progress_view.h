// SPDX-License-Identifier: Apache-2.0
// What the CLI shows the user: a one-line live progress display on a terminal and the
// end-of-job summary table.
#pragma once

#include <mutex>
#include <ostream>
#include <string>

#include "scanprep/v1/scanprep.pb.h"

namespace scanprep::client {

class ProgressView {
 public:
  // Draws on `out` only when `live` (stderr is a terminal).
  ProgressView(std::ostream& out, bool live) : out_(out), live_(live) {}
  // Thread-safe; called from the call's reader thread.
  void Update(const scanprep::v1::Progress& progress);
  // Clears the progress line.
  void Done();

 private:
  std::mutex mu_;
  std::ostream& out_;
  bool live_;
  bool drawn_ = false;
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

}  // namespace scanprep::client
