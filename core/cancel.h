// SPDX-License-Identifier: Apache-2.0
// Cooperative cancellation shared between a job's owner (the RPC) and its stages.
#pragma once

#include <atomic>
#include <cstddef>

#include "absl/status/status.h"

namespace scanprep {

class CancelToken {
 public:
  void Cancel() { cancelled_.store(true, std::memory_order_relaxed); }
  bool cancelled() const { return cancelled_.load(std::memory_order_relaxed); }
  // For sequential loops: whether the token fired, looked at only every 4096th iteration `i`,
  // which keeps the atomic load out of the loop's cost and still stops it within microseconds.
  bool CancelledAt(size_t i) const { return (i & 4095) == 0 && cancelled(); }
  absl::Status Check() const {
    return cancelled() ? absl::CancelledError("job cancelled") : absl::OkStatus();
  }

 private:
  std::atomic<bool> cancelled_{false};
};

}  // namespace scanprep
