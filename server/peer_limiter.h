// SPDX-License-Identifier: Apache-2.0
// Caps the calls one client host may have in progress at once, so a single machine cannot take
// every admission slot and queue place. Hosts are told apart by address only: the port changes
// with every connection.
#pragma once

#include <map>
#include <mutex>
#include <string>
#include <utility>

#include "absl/status/statusor.h"

namespace scanprep::server {

// gRPC's peer string without the port: "ipv4:10.0.0.7:51234" -> "ipv4:10.0.0.7",
// "ipv6:[::1]:51234" -> "ipv6:[::1]"; peers that are not IP addresses are returned unchanged.
std::string PeerHost(const std::string& peer);

class PeerLimiter {
 public:
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
    PeerLimiter* limiter_;
    std::string host_;
  };

  // RESOURCE_EXHAUSTED naming the limit when the peer's host already has `max` calls.
  absl::StatusOr<Lease> Acquire(const std::string& peer);
  int max_calls_per_peer() const { return max_; }

 private:
  void Release(const std::string& host);

  const int max_;
  std::mutex mu_;
  std::map<std::string, int> calls_;  // hosts with at least one call; erased at zero
};

}  // namespace scanprep::server
