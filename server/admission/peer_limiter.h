// SPDX-License-Identifier: Apache-2.0
// An optional cap on the calls one client host (client_identity.h) may have in progress at once,
// queued included (--max_calls_per_peer). Off by default: the admission queue already shares the
// slots fairly between hosts that contend (admission.h), so one host may use every place while
// nobody else waits. The cap is for operators who want a hard per-host share regardless.
#pragma once

#include <map>
#include <mutex>
#include <string>
#include <utility>

#include "absl/status/statusor.h"

namespace scanprep::server {

class PeerLimiter {
 public:
  // 0 = no cap.
  explicit PeerLimiter(int max_calls_per_peer) : max_(max_calls_per_peer) {}

  // One call in progress; destroying it ends the call's claim.
  class Lease {
   public:
    Lease(Lease&& o) noexcept : limiter_(std::exchange(o.limiter_, nullptr)), host_(o.host_) {}
    Lease& operator=(Lease&&) = delete;
    ~Lease();

   private:
    friend class PeerLimiter;
    Lease(PeerLimiter* limiter, std::string host) : limiter_(limiter), host_(std::move(host)) {}
    PeerLimiter* limiter_;  // null when there is no cap
    std::string host_;
  };

  // RESOURCE_EXHAUSTED naming the cap when `host` already has `max` calls.
  absl::StatusOr<Lease> Acquire(const std::string& host);
  int max_calls_per_peer() const { return max_; }

 private:
  void Release(const std::string& host);

  const int max_;
  std::mutex mu_;
  std::map<std::string, int> calls_;  // hosts with at least one call; erased at zero
};

}  // namespace scanprep::server
