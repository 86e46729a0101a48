// SPDX-License-Identifier: Apache-2.0
#include "core/stages/stage_reporter.h"

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace scanprep {

void StageReporter::Record(std::string_view name, double value) {
  report_.parameters[std::string(name)] = value;
}

void StageReporter::RecordForScan(std::string_view name, size_t scan, double value) {
  const std::string base(name);
  Record(scan_count_ > 1 ? absl::StrCat(base, ".scan", scan) : base, value);
}

void StageReporter::Warn(WarningCode code, std::string message,
                         std::map<std::string, std::string> params) {
  warnings_.push_back({code, std::move(message), std::move(params)});
}

double StageReporter::CapRadius(std::string_view what, double radius, double limit) {
  if (!(radius > limit)) return radius;
  const std::string& stage = report_.name;
  // One warning per stage (a job of 1,000 scans would otherwise say it 1,000 times); the
  // counter has them all.
  if (report_.parameters[absl::StrCat(stage, ".radii_capped")]++ > 0) return limit;
  Warn(WarningCode::kRadiusCapped,
       absl::StrFormat("%s: %s of %g mm is more than the data's own scale allows (%g mm, a "
                       "multiple of the global radius r_g); capped at %g mm. Check the job's "
                       "unit, the scanner metadata (spacing, uncertainty) and radius overrides",
                       stage, what, radius, limit, limit),
       {{"radius_mm", absl::StrCat(radius)}, {"limit_mm", absl::StrCat(limit)}});
  return limit;
}

}  // namespace scanprep
