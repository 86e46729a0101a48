// SPDX-License-Identifier: Apache-2.0
// Ends calls whose client sends or reads nothing for too long, or too little. A synchronous gRPC
// Read cannot time out, and a Write to a client that stops reading blocks once gRPC's flow-control
// window is full, so one thread watches every call's next deadline and cancels the calls that miss
// it (TryCancel is the only thing that ends a blocked Read or Write); without this a stream that
// sends no header, one point every few seconds, or never reads its result holds a server thread
// (and its slot) for as long as it likes.
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
 public:
  // A minimum rate's window, in first periods of grace (see Entry::rate_due).
  static constexpr int kCreditGraces = 2;
  // Which way the bytes counted against a minimum rate move.
  enum class Direction { kUpload, kDownload };

 private:
  struct Entry {
    grpc::ServerContext* context;
    absl::Time due = absl::InfiniteFuture();
    std::string overdue;  // what is late when the idle limit passes, for the reason
    absl::Time idle_due = absl::InfiniteFuture();
    absl::Duration limit;
    std::string limit_name;
    // The minimum rate, once set, as a deadline: the bytes moved so far are due by `rate_due`,
    // which each byte moves on by 1 / min_rate, and a pause (the server's time, not the
    // client's) by its length, but which each Expect brings back to at most one `rate_window`
    // past then: a client that sent fast at first banks at most one window of credit, so the
    // rate is judged over a sliding window, not averaged since the start. The window is
    // kCreditGraces first periods, so a client that stops altogether meets the idle limit
    // first, which names what it did not send or read.
    double min_rate = 0;  // bytes per second; 0 = none
    Direction direction = Direction::kUpload;
    std::string rate_name;
    absl::Time rate_since;  // when the rate was set, moved on by the pauses (for the reason)
    absl::Time rate_due = absl::InfiniteFuture();
    absl::Time paused_since = absl::InfiniteFuture();  // InfiniteFuture: not paused
    absl::Duration rate_window;
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
    // The client's next step (the next message arriving, or it taking the response being
    // written) must happen within `limit` (the server's `limit_name`), or the call is cancelled;
    // `overdue` says what is late then, e.g. "the header did not arrive".
    void Expect(absl::Duration limit, std::string_view limit_name, std::string overdue);
    // From now on the transfer in `direction` must also keep up with `bytes_per_second` (the
    // server's `limit_name`; 0 = no minimum) after a first `grace`, judged over a sliding window
    // of kCreditGraces × `grace`: a client that keeps every gap under the idle limit but sends or
    // reads next to nothing is ended too, however fast it began. Takes effect at the next Expect.
    void ExpectRate(Direction direction, double bytes_per_second, absl::Duration grace,
                    std::string_view limit_name);
    // No minimum rate from now on (the server is busy, not the client).
    void StopRate();
    // `bytes` more moved in the rate's direction (counted against the rate).
    void Transferred(uint64_t bytes);
    // Nothing is due from the client until the next Expect (the server is busy, not the
    // client); the time until then does not count against the rate.
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
