// Ends calls whose client sends nothing for too long. A synchronous gRPC Read cannot time out,
// so one thread watches every upload's next-message deadline and cancels the calls that miss
// it; without this a stream that sends one point every few seconds, or no header at all, holds a
// server thread (and its slot) for as long as it likes.
#pragma once

#include <condition_variable>
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
    absl::Duration limit;
    std::string limit_name;
    std::string reason;  // set when the watch cancelled the call
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
