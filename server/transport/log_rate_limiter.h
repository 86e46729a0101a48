// SPDX-License-Identifier: Apache-2.0
// Bounds how many lines per second a log writes: under a flood of failing calls (garbage
// connections) every call would otherwise log a line, and stderr grew by 480 KiB/s.
#pragma once

#include <cstdint>
#include <optional>

#include "absl/time/time.h"

namespace scanprep::server {

// Admits at most `max_per_second` lines in each one-second window and counts the rest, so that
// the next admitted line can say how many were dropped. Not thread-safe (the caller's lock).
class LogRateLimiter {
 public:
  explicit LogRateLimiter(int max_per_second) : max_per_second_(max_per_second) {}

  // nullopt: drop this line. Otherwise write it, after a note of the returned number of lines
  // dropped since the last admitted one (0 = none).
  std::optional<int64_t> Admit(absl::Time now);
  int max_per_second() const { return max_per_second_; }

 private:
  const int max_per_second_;
  absl::Time window_start_ = absl::InfinitePast();
  int admitted_in_window_ = 0;
  int64_t suppressed_ = 0;
};

}  // namespace scanprep::server
