// SPDX-License-Identifier: Apache-2.0
#include "server/transport/log_rate_limiter.h"

namespace scanprep::server {

std::optional<int64_t> LogRateLimiter::Admit(absl::Time now) {
  if (now - window_start_ >= absl::Seconds(1)) {
    window_start_ = now;
    admitted_in_window_ = 0;
  }
  if (admitted_in_window_ >= max_per_second_) {
    ++suppressed_;
    return std::nullopt;
  }
  ++admitted_in_window_;
  const int64_t dropped = suppressed_;
  suppressed_ = 0;
  return dropped;
}

}  // namespace scanprep::server
