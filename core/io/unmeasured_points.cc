// SPDX-License-Identifier: Apache-2.0
#include "core/io/unmeasured_points.h"

#include "absl/strings/str_cat.h"

namespace scanprep::io {
namespace {

constexpr char kWhy[] = "no measurement (a NaN or infinite coordinate, or an invalid state)";

}  // namespace

absl::Status NoPointsError(const std::string& name) {
  return absl::InvalidArgumentError(absl::StrCat(name, ": no points in the file"));
}

void UnmeasuredPoints::Count(uint64_t index, const std::string& within, size_t scan) {
  if (per_scan_.size() <= scan) per_scan_.resize(scan + 1, 0);
  ++per_scan_[scan];
  if (count_++ > 0) return;
  first_ = absl::StrCat(unit_, " ", index, within.empty() ? "" : " of ", within);
}

void UnmeasuredPoints::Record(std::vector<ScanMeta>& scans) const {
  for (size_t s = 0; s < per_scan_.size() && s < scans.size(); ++s) {
    scans[s].points_invalid += per_scan_[s];
  }
}

absl::Status UnmeasuredPoints::Finish(const std::string& name, uint64_t kept,
                                      std::vector<std::string>& warnings) const {
  if (kept == 0 && count_ == 0) return NoPointsError(name);
  if (kept == 0) {
    return absl::InvalidArgumentError(absl::StrCat(NoPointsError(name).message(), ": all ", count_,
                                                   " have ", kWhy, "; the first is ", first_));
  }
  if (count_ > 0) {
    warnings.push_back(absl::StrCat(name, ": ", count_, " of ", kept + count_, " points have ",
                                    kWhy, " and were left out; the first is ", first_));
  }
  return absl::OkStatus();
}

}  // namespace scanprep::io
