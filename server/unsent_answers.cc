// SPDX-License-Identifier: Apache-2.0
#include "server/unsent_answers.h"

#include <string_view>
#include <utility>

#include "absl/strings/str_cat.h"
#include "scanprep/v1/scanprep.grpc.pb.h"

namespace scanprep::server {
namespace {

// Releases a ProcessUnary call's holdings when the call ends: its answer and status go in one
// batch, whose completion ends the call, so this is when the answer has left (or the call was
// cancelled or failed with it unsent).
class AnswerSent final : public grpc::experimental::Interceptor {
 public:
  AnswerSent(UnsentAnswers& answers, const grpc::ServerContextBase* context)
      : answers_(answers), context_(context) {}
  ~AnswerSent() override { answers_.Release(context_); }

  void Intercept(grpc::experimental::InterceptorBatchMethods* methods) override {
    methods->Proceed();
  }

 private:
  UnsentAnswers& answers_;
  const grpc::ServerContextBase* context_;
};

class AnswerSentFactory final : public grpc::experimental::ServerInterceptorFactoryInterface {
 public:
  explicit AnswerSentFactory(UnsentAnswers& answers)
      : answers_(answers),
        method_(absl::StrCat("/", v1::ScanPrep::service_full_name(), "/ProcessUnary")) {}

  grpc::experimental::Interceptor* CreateServerInterceptor(
      grpc::experimental::ServerRpcInfo* info) override {
    if (std::string_view(info->method()) != method_) return nullptr;
    return new AnswerSent(answers_, info->server_context());
  }

 private:
  UnsentAnswers& answers_;
  const std::string method_;
};

}  // namespace

void UnsentAnswers::Keep(grpc::ServerContext* context, Held held, uint64_t bytes) {
  // The call's handler has returned only once Keep has: the interceptor's Release comes after.
  auto watch = std::unique_ptr<IdleWatch::Call>(new IdleWatch::Call(watch_.Watch(context)));
  const absl::Duration limit =
      idle_ + (min_rate_ > 0 ? absl::Seconds(static_cast<double>(bytes) / min_rate_)
                             : absl::ZeroDuration());
  watch->Expect(limit, "idle_timeout + its bytes at min_download_rate",
                absl::StrCat("the client did not read its answer of ", bytes, " bytes"));
  std::lock_guard lock(mu_);
  entries_.emplace(context, Entry{.held = std::move(held), .watch = std::move(watch)});
}

void UnsentAnswers::Release(const grpc::ServerContextBase* context) {
  std::optional<Entry> entry;
  {
    std::lock_guard lock(mu_);
    auto it = entries_.find(context);
    if (it == entries_.end()) return;
    entry.emplace(std::move(it->second));
    entries_.erase(it);
  }
  // Outside the lock: the ticket's release grants slots to waiting calls.
  if (const std::string reason = entry->watch->reason(); !reason.empty()) {
    log_.Write(
        CallLog::kWarning, "answer",
        {{"peer", entry->held.peer},
         {"client", entry->held.client},
         {"job", entry->held.job_id, kLoggedClientTextBytes},
         {"status", "DEADLINE_EXCEEDED"},
         {"message", absl::StrCat(reason, "; the server ended the call"), kLoggedMessageBytes}});
  }
}

std::unique_ptr<grpc::experimental::ServerInterceptorFactoryInterface>
UnsentAnswers::InterceptorFactory() {
  return std::make_unique<AnswerSentFactory>(*this);
}

}  // namespace scanprep::server
