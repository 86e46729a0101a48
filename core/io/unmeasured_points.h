// SPDX-License-Identifier: Apache-2.0
// One rule for points without a position in every reader: a NaN or infinite coordinate (or E57's
// invalid state) is a scanner's "no return" (an organised PCD's or PLY's empty grid cell, a
// text file's "nan nan nan" row), so the point is left out, counted, and named in one warning
// with the first one's place; never silently. A file left with no point at all is refused with
// the same message whatever its format.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "core/base/point_cloud.h"

namespace scanprep::io {

// INVALID_ARGUMENT "NAME: no points in the file": a file with no point, in any format.
absl::Status NoPointsError(const std::string& name);

class UnmeasuredPoints {
 public:
  // `unit`: what the file calls one record, for the first one's place ("line", "vertex", "point").
  explicit UnmeasuredPoints(std::string unit) : unit_(std::move(unit)) {}

  // A point left out; `index` is its place in the file's terms (a line number, a vertex index),
  // `within` what it is counted in, when the file has several parts (an E57 scan).
  // `scan`: the index, in the cloud's scans, of the scan the point belonged to.
  void Count(uint64_t index, const std::string& within = "", size_t scan = 0);
  uint64_t count() const { return count_; }
  // Adds each scan's count to its ScanMeta::points_invalid (call once the scans exist).
  void Record(std::vector<ScanMeta>& scans) const;

  // After reading, `kept` points kept: NoPointsError (saying that all were unmeasured, when
  // they were) for none; else a warning appended when any was left out.
  absl::Status Finish(const std::string& name, uint64_t kept,
                      std::vector<std::string>& warnings) const;

 private:
  std::string unit_;
  uint64_t count_ = 0;
  std::vector<uint64_t> per_scan_;
  std::string first_;  // the first one's place, e.g. "line 4"
};

}  // namespace scanprep::io
