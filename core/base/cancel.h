// SPDX-License-Identifier: Apache-2.0
// Cooperative cancellation shared between a job's owner (the RPC) and its stages, and the channel
// through which the stages' parallel loops report the work they finished (for progress).
#pragma once

#include <atomic>
#include <cstddef>

#include "absl/status/status.h"

namespace scanprep {

// Told how many loop items a job finished; called from any thread, often (once per block).
class WorkMeter {
 public:
  virtual ~WorkMeter() = default;
  virtual void Worked(size_t items) = 0;
};

class CancelToken {
 public:
  CancelToken() = default;
  // A token that fires when `parent` does (or when cancelled itself) and tells `meter` about the
  // work of the loops run with it; both must outlive it.
  CancelToken(const CancelToken& parent, WorkMeter& meter) : parent_(&parent), meter_(&meter) {}
  CancelToken& operator=(const CancelToken&) = delete;

  void Cancel() { cancelled_.store(true, std::memory_order_relaxed); }
  bool cancelled() const {
    return cancelled_.load(std::memory_order_relaxed) ||
           (parent_ != nullptr && parent_->cancelled());
  }
  // For sequential loops: whether the token fired, looked at only every 4096th iteration `i`,
  // which keeps the atomic load out of the loop's cost and still stops it within microseconds.
  bool CancelledAt(size_t i) const { return (i & 4095) == 0 && cancelled(); }
  absl::Status Check() const {
    return cancelled() ? absl::CancelledError("job cancelled") : absl::OkStatus();
  }
  // A loop finished `items` more items (ParallelFor calls this per block).
  void Worked(size_t items) const {
    if (meter_ != nullptr) meter_->Worked(items);
  }

 private:
  std::atomic<bool> cancelled_{false};
  const CancelToken* parent_ = nullptr;
  WorkMeter* meter_ = nullptr;
};

// The token of the ParallelFor block this thread runs, for work deep inside a loop body that is
// not handed one (the kd-tree a grid query builds on first need); null outside a loop.
inline thread_local const CancelToken* running_loop_token = nullptr;

}  // namespace scanprep
