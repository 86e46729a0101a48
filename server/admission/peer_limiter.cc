// SPDX-License-Identifier: Apache-2.0
#include "server/admission/peer_limiter.h"

#include "absl/strings/str_cat.h"
#include "wire/error_details.h"

namespace scanprep::server {

PeerLimiter::Lease::~Lease() {
  if (limiter_ != nullptr) limiter_->Release(host_);
}

absl::StatusOr<PeerLimiter::Lease> PeerLimiter::Acquire(const std::string& host) {
  if (max_ == 0) return Lease(nullptr, host);
  std::lock_guard lock(mu_);
  int& calls = calls_[host];
  if (calls >= max_) {
    // A retry succeeds once one of the host's calls ended, which the server cannot predict.
    return WithReason(absl::ResourceExhaustedError(absl::StrCat(
                          host, " already has ", calls,
                          " calls in progress, the server's limit of concurrent calls per client "
                          "host (max_calls_per_peer); wait for one to end")),
                      "PEER_LIMIT", absl::Seconds(1));
  }
  ++calls;
  return Lease(this, host);
}

void PeerLimiter::Release(const std::string& host) {
  std::lock_guard lock(mu_);
  auto it = calls_.find(host);
  if (--it->second == 0) calls_.erase(it);
}

}  // namespace scanprep::server
