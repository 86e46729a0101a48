#include "server/idle_watch.h"

#include <algorithm>

#include "absl/strings/str_cat.h"

namespace scanprep::server {

IdleWatch::IdleWatch() : thread_([this] { Run(); }) {}

IdleWatch::~IdleWatch() {
  {
    std::lock_guard lock(mu_);
    stop_ = true;
  }
  changed_.notify_all();
  thread_.join();
}

IdleWatch::Call IdleWatch::Watch(grpc::ServerContext* context) {
  std::lock_guard lock(mu_);
  entries_.push_back(Entry{.context = context});
  return Call(this, std::prev(entries_.end()));
}

IdleWatch::Call::~Call() {
  std::lock_guard lock(watch_->mu_);
  watch_->entries_.erase(entry_);
}

void IdleWatch::Call::Expect(absl::Duration limit, std::string_view limit_name,
                             std::string awaited) {
  {
    std::lock_guard lock(watch_->mu_);
    entry_->due = absl::Now() + limit;
    entry_->limit = limit;
    entry_->limit_name = std::string(limit_name);
    entry_->awaited = std::move(awaited);
  }
  watch_->changed_.notify_all();
}

void IdleWatch::Call::Pause() {
  std::lock_guard lock(watch_->mu_);
  entry_->due = absl::InfiniteFuture();
}

std::string IdleWatch::Call::reason() const {
  std::lock_guard lock(watch_->mu_);
  return entry_->reason;
}

void IdleWatch::Run() {
  std::unique_lock lock(mu_);
  while (!stop_) {
    const absl::Time now = absl::Now();
    absl::Time next = absl::InfiniteFuture();
    for (Entry& e : entries_) {
      if (e.due <= now) {
        // Under the lock, so the entry (and its call) cannot end meanwhile.
        e.reason = absl::StrCat(e.awaited, " did not arrive within ",
                                absl::FormatDuration(e.limit), " (", e.limit_name, ")");
        e.due = absl::InfiniteFuture();
        e.context->TryCancel();
      }
      next = std::min(next, e.due);
    }
    if (next == absl::InfiniteFuture()) {
      changed_.wait(lock);
    } else {
      changed_.wait_until(lock, absl::ToChronoTime(next));
    }
  }
}

}  // namespace scanprep::server
