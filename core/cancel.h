// Cooperative cancellation shared between a job's owner (the RPC) and its stages.
#pragma once

#include <atomic>

#include "absl/status/status.h"

namespace scanprep {

class CancelToken {
 public:
  void Cancel() { cancelled_.store(true, std::memory_order_relaxed); }
  bool cancelled() const { return cancelled_.load(std::memory_order_relaxed); }
  absl::Status Check() const {
    return cancelled() ? absl::CancelledError("job cancelled") : absl::OkStatus();
  }

 private:
  std::atomic<bool> cancelled_{false};
};

}  // namespace scanprep
