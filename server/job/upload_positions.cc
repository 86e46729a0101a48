// SPDX-License-Identifier: Apache-2.0
#include "server/job/upload_positions.h"

#include <algorithm>

namespace scanprep::server {

uint64_t UploadPositions::Of(uint64_t index) const {
  return index + (std::upper_bound(shifted_.begin(), shifted_.end(), index) - shifted_.begin());
}

}  // namespace scanprep::server
