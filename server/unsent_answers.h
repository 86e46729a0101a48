// SPDX-License-Identifier: Apache-2.0
// A ProcessUnary answer leaves after its handler returned: gRPC's synchronous server sends it then,
// and a client that does not read it keeps it (the message and its serialized copy, up to
// --max_message_bytes each) and the handler's thread for as long as its connection lasts. So what
// the call held while it ran, its slot with the memory reservation and its place under the
// per-host cap, stays held until the answer has left, and the answer must be read as a stream's
// download is: within the idle limit plus its bytes at the minimum download rate, or the call is
// cancelled. An interceptor (UnsentAnswers::InterceptorFactory) says when the call ended.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include <grpcpp/grpcpp.h>
#include <grpcpp/support/server_interceptor.h>

#include "server/admission/admission.h"
#include "server/admission/peer_limiter.h"
#include "server/transport/call_log.h"
#include "server/transport/idle_watch.h"

namespace scanprep::server {

class UnsentAnswers {
 public:
  // What a call holds until its answer has left.
  struct Held {
    std::optional<AdmissionQueue::Ticket> ticket;
    std::optional<PeerLimiter::Lease> lease;
    std::string peer, client, job_id;  // for the log line of an answer left unread
  };

  // `idle` is the limit on a client's wait, `min_rate` the download rate (bytes per second, 0 =
  // none) an answer is read at.
  UnsentAnswers(IdleWatch& watch, CallLog& log, absl::Duration idle, double min_rate)
      : watch_(watch), log_(log), idle_(idle), min_rate_(min_rate) {}

  // Holds `held` until Release(context): the answer of `bytes` is being sent.
  void Keep(grpc::ServerContext* context, Held held, uint64_t bytes);
  // The answer left or the call ended: what it held is let go (and an answer the watch ended
  // unread is logged). Nothing when the call keeps nothing.
  void Release(const grpc::ServerContextBase* context);

  // The interceptor that calls Release for a ProcessUnary call when the call ends.
  std::unique_ptr<grpc::experimental::ServerInterceptorFactoryInterface> InterceptorFactory();

 private:
  struct Entry {
    Held held;
    std::unique_ptr<IdleWatch::Call> watch;
  };
  IdleWatch& watch_;
  CallLog& log_;
  const absl::Duration idle_;
  const double min_rate_;
  std::mutex mu_;
  std::map<const grpc::ServerContextBase*, Entry> entries_;
};

}  // namespace scanprep::server
