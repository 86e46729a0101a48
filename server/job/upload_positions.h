// SPDX-License-Identifier: Apache-2.0
// Where each point of a job's cloud stood in its upload (PointChunk.source_index). The cloud
// holds the valid points in upload order, so a point's position is its cloud index plus the
// points left out before it; only those are stored, never a value per point.
#pragma once

#include <cstdint>
#include <vector>

namespace scanprep::server {

class UploadPositions {
 public:
  // Records that the point at upload position `position` was left out; positions in increasing
  // order, as the upload delivers them.
  void Exclude(uint64_t position) { shifted_.push_back(position - shifted_.size()); }

  // The upload position of the cloud's point `index`: index + the excluded points before it,
  // which are those whose shifted position (position − excluded before it) is at most index.
  uint64_t Of(uint64_t index) const;

 private:
  // Each excluded point's position less the number excluded before it: non-decreasing.
  std::vector<uint64_t> shifted_;
};

}  // namespace scanprep::server
