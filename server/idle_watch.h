// SPDX-License-Identifier: Apache-2.0
// Ends calls whose client sends nothing for too long, or too little. A synchronous gRPC Read
// cannot time out, so one thread watches every upload's next-message deadline and cancels the
// calls that miss it; without this a stream that sends no header, or one point every few seconds,
// holds a server thread (and its slot) for as long as it likes.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <list>
#include <mutex>
#include <string>
#include <string_view>
#include <thread>

#include <grpcpp/grpcpp.h>

#include "absl/time/time.h"

namespace scanprep::server {

class IdleWatch {
  struct Entry {
    grpc::ServerContext* context;
    absl::Time due = absl::InfiniteFuture();
    std::string awaited;  // what the call waits for, for the reason
    absl::Time idle_due = absl::InfiniteFuture();
    absl::Duration limit;
    std::string limit_name;
    // The minimum average rate, once set: `rate_bytes` must have arrived by
    // rate_since + rate_grace + rate_bytes / min_rate.
    double min_rate = 0;  // bytes per second; 0 = none
    std::string rate_name;
    absl::Time rate_since;
    absl::Duration rate_grace;
    uint64_t rate_bytes = 0;
    std::string reason;  // set when the watch cancelled the call
    // Why the call is ended when `due` passed at `now`: the idle or the rate limit.
    std::string Expired(absl::Time now) const;
  };

 public:
  IdleWatch();
  ~IdleWatch();
  IdleWatch(const IdleWatch&) = delete;
  IdleWatch& operator=(const IdleWatch&) = delete;

  // One call's registration; destroy it before the call's handler returns.
  class Call {
   public:
    ~Call();
    Call(const Call&) = delete;
    Call& operator=(const Call&) = delete;
    // The next message (`awaited`, e.g. "the header") must arrive within `limit` (the server's
    // `limit_name`), or the call is cancelled.
    void Expect(absl::Duration limit, std::string_view limit_name, std::string awaited);
    // From now on the upload must also average at least `bytes_per_second` (the server's
    // `limit_name`; 0 = no minimum), measured after a first `grace`: a client that keeps every
    // gap under the idle limit but sends next to nothing is ended too. Takes effect at the next
    // Expect.
    void ExpectRate(double bytes_per_second, absl::Duration grace, std::string_view limit_name);
    // `bytes` more arrived (counted against the rate).
    void Received(uint64_t bytes);
    // No message is due (the server is busy, not the client).
    void Pause();
    // Why the watch cancelled the call; empty if it did not.
    std::string reason() const;

   private:
    friend class IdleWatch;
    Call(IdleWatch* watch, std::list<Entry>::iterator entry) : watch_(watch), entry_(entry) {}
    IdleWatch* watch_;
    std::list<Entry>::iterator entry_;
  };

  Call Watch(grpc::ServerContext* context);

 private:
  void Run();

  mutable std::mutex mu_;
  std::condition_variable changed_;
  std::list<Entry> entries_;
  bool stop_ = false;
  std::thread thread_;  // last: starts once the rest is built
};

}  // namespace scanprep::server
