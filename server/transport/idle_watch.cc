// SPDX-License-Identifier: Apache-2.0
#include "server/transport/idle_watch.h"

#include <algorithm>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace scanprep::server {

std::string IdleWatch::Entry::Expired(absl::Time now) const {
  if (due == idle_due) {
    return absl::StrCat(overdue, " within ", absl::FormatDuration(limit), " (", limit_name, ")");
  }
  return absl::StrFormat(
      "%s %d bytes in %.1f s of waiting for the client since %s, falling behind the minimum of "
      "%.0f bytes/s judged over a sliding window of %s (%s)",
      direction == Direction::kUpload ? "the upload sent" : "the client read", rate_bytes,
      absl::ToDoubleSeconds(now - rate_since),
      direction == Direction::kUpload ? "it was admitted" : "the download began", min_rate,
      absl::FormatDuration(rate_window), rate_name);
}

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
                             std::string overdue) {
  {
    std::lock_guard lock(watch_->mu_);
    Entry& e = *entry_;
    const absl::Time now = absl::Now();
    if (e.paused_since != absl::InfiniteFuture()) {
      e.rate_since += now - e.paused_since;
      e.rate_due += now - e.paused_since;
      e.paused_since = absl::InfiniteFuture();
    }
    e.idle_due = now + limit;
    e.due = e.idle_due;
    if (e.min_rate > 0) {
      // At most one window of credit from here, where the client's time starts again.
      e.rate_due = std::min(e.rate_due, now + e.rate_window);
      e.due = std::min(e.due, e.rate_due);
    }
    e.limit = limit;
    e.limit_name = std::string(limit_name);
    e.overdue = std::move(overdue);
  }
  watch_->changed_.notify_all();
}

void IdleWatch::Call::ExpectRate(Direction direction, double bytes_per_second, absl::Duration grace,
                                 std::string_view limit_name) {
  std::lock_guard lock(watch_->mu_);
  entry_->direction = direction;
  entry_->min_rate = bytes_per_second;
  entry_->rate_name = std::string(limit_name);
  entry_->rate_since = absl::Now();
  entry_->rate_due = entry_->rate_since + grace;
  entry_->paused_since = absl::InfiniteFuture();
  entry_->rate_window = kCreditGraces * grace;
  entry_->rate_bytes = 0;
}

void IdleWatch::Call::StopRate() {
  std::lock_guard lock(watch_->mu_);
  entry_->min_rate = 0;
}

void IdleWatch::Call::Transferred(uint64_t bytes) {
  std::lock_guard lock(watch_->mu_);
  Entry& e = *entry_;
  e.rate_bytes += bytes;
  if (e.min_rate > 0) e.rate_due += absl::Seconds(static_cast<double>(bytes) / e.min_rate);
}

void IdleWatch::Call::Pause() {
  std::lock_guard lock(watch_->mu_);
  entry_->due = absl::InfiniteFuture();
  if (entry_->paused_since == absl::InfiniteFuture()) entry_->paused_since = absl::Now();
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
        e.reason = e.Expired(now);
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
