// SPDX-License-Identifier: Apache-2.0
// What a stage function tells the job while it runs: the values it derived (into its report
// entry), warnings, progress, and the job's cancel token, which its loops poll and which meters
// them. The runner makes one per stage; a test makes its own (no runner, no plan).
#pragma once

#include <cstddef>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "core/base/cancel.h"
#include "core/stages/report.h"
#include "core/stages/warning.h"

namespace scanprep {

// The running stage's progress, kept by the runner.
class StageMeter {
 public:
  virtual ~StageMeter() = default;
  virtual void Progress(double fraction) = 0;
  virtual void ExpectWork(double items) = 0;
};

class StageReporter {
 public:
  // `report` is the stage's entry (its name names the stage in warnings); `scan_count` the job's
  // scans (RecordForScan); `meter` may be null where nobody watches the progress.
  StageReporter(StageReport& report, std::vector<Warning>& warnings, const CancelToken& cancel,
                size_t scan_count, StageMeter* meter = nullptr)
      : report_(report),
        warnings_(warnings),
        cancel_(cancel),
        scan_count_(scan_count),
        meter_(meter) {}

  // The job's token, which also meters the stage's loops for progress.
  const CancelToken& cancel() const { return cancel_; }
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
  void Progress(double fraction) {
    if (meter_) meter_->Progress(fraction);
  }
  // The stage will work through `items` loop items instead of work_per_point × n (for work that
  // depends on parameters, e.g. iterations).
  void ExpectWork(double items) {
    if (meter_) meter_->ExpectWork(items);
  }

 private:
  StageReport& report_;
  std::vector<Warning>& warnings_;
  const CancelToken& cancel_;
  size_t scan_count_;
  StageMeter* meter_;
};

}  // namespace scanprep
