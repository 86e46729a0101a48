// SPDX-License-Identifier: Apache-2.0
#include "server/admission/admission.h"

#include "server/admission/memory_reservation.h"
#include "wire/error_details.h"

#include <algorithm>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace scanprep::server {
namespace {

// How often a waiting call looks at its cancellation (client gone or deadline passed).
constexpr std::chrono::milliseconds kPollInterval(25);

// RESOURCE_EXHAUSTED for a job that could never run: its claim exceeds the whole capacity.
absl::Status ExceedsCapacityError(uint64_t claim_bytes, uint64_t capacity_bytes) {
  absl::Status refused = WithReason(
      absl::ResourceExhaustedError(absl::StrCat(
          "the job's estimated memory of ", FormatMiB(claim_bytes), " (", claim_bytes,
          " bytes, from header.total_points) exceeds the server's whole memory capacity of ",
          FormatMiB(capacity_bytes), " (", capacity_bytes,
          " bytes, memory_capacity), so it could never run here; send fewer points per job or "
          "raise the server's --memory_capacity")),
      "JOB_EXCEEDS_MEMORY");
  refused = WithMetadata(std::move(refused), "estimate_bytes", absl::StrCat(claim_bytes));
  // The key clients read (docs/api.md), named before the capacity was.
  return WithMetadata(std::move(refused), "budget_bytes", absl::StrCat(capacity_bytes));
}

absl::Status DrainingError() {
  return WithReason(absl::UnavailableError("the server is shutting down (draining) and takes no "
                                           "new jobs; retry on another replica"),
                    "SHUTTING_DOWN", kRetryOnAnotherReplica);
}

}  // namespace

AdmissionQueue::AdmissionQueue(AdmissionOptions options, AdmissionObserver& observer)
    : options_(std::move(options)), observer_(observer) {
  observer_.AdmissionConfigured(options_.max_queued_jobs, options_.memory_capacity_bytes);
  PublishLocked();
}

AdmissionQueue::Slot::~Slot() {
  if (queue_ != nullptr) queue_->Release(since_, holder_);
}

uint64_t AdmissionQueue::Slot::claim_bytes() const {
  std::lock_guard lock(queue_->mu_);
  return holder_->claim;
}

uint64_t AdmissionQueue::Slot::reserved_bytes() const {
  std::lock_guard lock(queue_->mu_);
  return holder_->reserved;
}

absl::Status AdmissionQueue::Slot::Reserve(uint64_t bytes, const std::function<bool()>& cancelled) {
  AdmissionQueue& q = *queue_;
  std::unique_lock lock(q.mu_);
  Waiter self{.claim = holder_->claim,
              .reserve = std::min(bytes, holder_->claim),
              .holds_slot = true,
              .holder = holder_};
  if (self.reserve <= holder_->reserved) return absl::OkStatus();
  if (q.FitsLocked(self)) {  // any safe reservation may go first (GrantLocked)
    q.reserved_bytes_ += self.reserve - holder_->reserved;
    holder_->reserved = self.reserve;
    q.PublishLocked();
    return absl::OkStatus();
  }
  const auto position = q.growing_.insert(q.growing_.end(), &self);
  q.WaitLocked(lock, self, cancelled);
  if (self.granted) return absl::OkStatus();  // GrantLocked took it off the list
  q.growing_.erase(position);
  q.GrantLocked();  // the reservations behind it may be safe now
  q.PublishLocked();
  return absl::CancelledError(
      "the call was cancelled or its deadline passed while it waited for memory");
}

absl::StatusOr<AdmissionQueue::Slot> AdmissionQueue::Admit(const std::string& host,
                                                           uint64_t claim_bytes,
                                                           uint64_t reserve_bytes,
                                                           absl::Time deadline,
                                                           const std::function<bool()>& cancelled) {
  const absl::Time arrived = options_.now();
  std::unique_lock lock(mu_);
  if (draining_) {
    observer_.Refused(AdmissionRefusal::kDraining);
    return DrainingError();
  }
  if (claim_bytes > options_.memory_capacity_bytes) {
    observer_.Refused(AdmissionRefusal::kMemory);
    return ExceedsCapacityError(claim_bytes, options_.memory_capacity_bytes);
  }
  Waiter self{.claim = claim_bytes, .reserve = std::min(reserve_bytes, claim_bytes), .host = host};
  if (waiting_.empty() && FitsLocked(self)) {
    reserved_bytes_ += self.reserve;
    const auto holder = holders_.insert(holders_.end(), Holder{claim_bytes, self.reserve, host});
    AddCallLocked(host);
    hosts_[host].last_served = ++grants_;
    PublishLocked();
    observer_.Admitted(0);
    return Slot(this, arrived, holder);
  }
  const double expected = ExpectedWaitLocked();
  const double remaining = absl::ToDoubleSeconds(deadline - arrived);
  // A call that would be refused for its deadline anyway displaces nobody.
  if (static_cast<int>(waiting_.size()) >= options_.max_queued_jobs &&
      (expected > remaining || !DisplaceForLocked(host))) {
    observer_.Refused(AdmissionRefusal::kQueueFull);
    return QueueFullErrorLocked(/*displaced=*/false);
  }
  if (expected > remaining) {
    observer_.Refused(AdmissionRefusal::kDeadline);
    return absl::DeadlineExceededError(absl::StrFormat(
        "expected wait %.3g s exceeds the deadline %.3g s (%d jobs queued, mean job time %.3g s)",
        expected, std::max(0.0, remaining), static_cast<int>(waiting_.size()), mean_hold_seconds_));
  }

  const auto position = waiting_.insert(waiting_.end(), &self);
  AddCallLocked(host);
  PublishLocked();
  WaitLocked(lock, self, cancelled);
  if (self.granted) {  // GrantLocked already moved it from the queue to a slot
    observer_.Admitted(absl::ToDoubleSeconds(options_.now() - arrived));
    return Slot(this, options_.now(), self.holder);
  }
  if (self.displaced) {  // DisplaceForLocked already took it off the queue
    observer_.Refused(AdmissionRefusal::kQueueFull);
    return QueueFullErrorLocked(/*displaced=*/true);
  }
  waiting_.erase(position);
  EndCallLocked(host);
  if (waiting_for_memory_ == &self) waiting_for_memory_ = nullptr;
  GrantLocked();  // the calls behind it may fit now
  PublishLocked();
  if (draining_) {
    observer_.Refused(AdmissionRefusal::kDraining);
    return DrainingError();
  }
  return absl::CancelledError("the call was cancelled or its deadline passed while queued");
}

bool AdmissionQueue::DisplaceForLocked(const std::string& host) {
  const auto mine = hosts_.find(host);
  int most = (mine == hosts_.end() ? 0 : mine->second.calls) + 1;
  auto victim = waiting_.rend();
  for (auto it = waiting_.rbegin(); it != waiting_.rend(); ++it) {  // newest first
    if (*it == waiting_for_memory_) continue;                       // it keeps its turn
    const int calls = hosts_.at((*it)->host).calls;
    if (calls > most) {
      most = calls;
      victim = it;
    }
  }
  if (victim == waiting_.rend()) return false;
  Waiter* displaced = *victim;
  waiting_.erase(std::next(victim).base());
  EndCallLocked(displaced->host);
  displaced->displaced = true;
  changed_.notify_all();
  return true;
}

absl::Status AdmissionQueue::QueueFullErrorLocked(bool displaced) const {
  // Retry once the queue can be expected to have moved; at least a second, so that refused
  // clients do not hammer a server that has not finished a job yet.
  const int in_flight = static_cast<int>(holders_.size());
  return WithReason(
      absl::ResourceExhaustedError(absl::StrCat(
          displaced ? "this call's place in the queue went to a call of another client host, "
                      "which held or awaited fewer jobs than yours (hosts keep equal shares of "
                      "the queue when they contend): "
                    : "",
          in_flight >= options_.max_concurrent_jobs
              ? absl::StrCat("the server is running its limit of ", options_.max_concurrent_jobs,
                             " concurrent jobs (max_concurrent_jobs)")
              : absl::StrCat("the server's ", in_flight, " running jobs hold ",
                             FormatMiB(reserved_bytes_), " of its ",
                             FormatMiB(options_.memory_capacity_bytes),
                             " memory capacity (memory_capacity)"),
          " and its queue of ", options_.max_queued_jobs,
          " waiting jobs (max_queued_jobs) is full; retry later or on another replica")),
      "QUEUE_FULL", absl::Seconds(std::max(1.0, ExpectedWaitLocked())));
}

void AdmissionQueue::WaitLocked(std::unique_lock<std::mutex>& lock, Waiter& self,
                                const std::function<bool()>& cancelled) {
  // A holder keeps its slot through a drain: only calls still waiting for one are released.
  const auto done = [&] {
    return self.granted || self.displaced || (draining_ && !self.holds_slot);
  };
  while (!done()) {
    if (changed_.wait_for(lock, kPollInterval, done)) break;
    if (cancelled()) break;
  }
}

void AdmissionQueue::Release(absl::Time since, std::list<Holder>::iterator holder) {
  const double held = absl::ToDoubleSeconds(options_.now() - since);
  std::lock_guard lock(mu_);
  mean_hold_seconds_ =
      have_mean_ ? (1 - options_.mean_weight) * mean_hold_seconds_ + options_.mean_weight * held
                 : held;
  have_mean_ = true;
  reserved_bytes_ -= holder->reserved;
  EndCallLocked(holder->host);
  holders_.erase(holder);
  GrantLocked();
  PublishLocked();
}

bool AdmissionQueue::FitsLocked(const Waiter& waiter) const {
  if (!waiter.holds_slot && static_cast<int>(holders_.size()) >= options_.max_concurrent_jobs) {
    return false;
  }
  const uint64_t extra = waiter.reserve - (waiter.holds_slot ? waiter.holder->reserved : 0);
  return extra <= options_.memory_capacity_bytes - reserved_bytes_ && SafeLocked(waiter);
}

bool AdmissionQueue::SafeLocked(const Waiter& waiter) const {
  // What each holder still needs and what it returns when done, with the waiter's request in
  // place. Served smallest need first: if any order lets every holder finish, that one does (the
  // free bytes only grow as holders finish).
  struct Claim {
    uint64_t need;
    uint64_t reserved;
  };
  std::vector<Claim> claims;
  claims.reserve(holders_.size() + 1);
  for (auto it = holders_.begin(); it != holders_.end(); ++it) {
    const uint64_t reserved =
        waiter.holds_slot && it == waiter.holder ? waiter.reserve : it->reserved;
    claims.push_back({it->claim - reserved, reserved});
  }
  if (!waiter.holds_slot) claims.push_back({waiter.claim - waiter.reserve, waiter.reserve});
  uint64_t reserved = 0;
  for (const Claim& c : claims) reserved += c.reserved;
  std::sort(claims.begin(), claims.end(),
            [](const Claim& a, const Claim& b) { return a.need < b.need; });
  uint64_t free = options_.memory_capacity_bytes - reserved;
  for (const Claim& c : claims) {
    if (c.need > free) return false;
    free += c.reserved;
  }
  return true;
}

void AdmissionQueue::GrantLocked() {
  bool granted = false;
  // Reservations first, any that is safe: their holders run once their claims are complete, and
  // free everything when done.
  for (auto it = growing_.begin(); it != growing_.end();) {
    Waiter* next = *it;
    if (!FitsLocked(*next)) {
      ++it;
      continue;
    }
    reserved_bytes_ += next->reserve - next->holder->reserved;
    next->holder->reserved = next->reserve;
    next->granted = true;
    it = growing_.erase(it);
    granted = true;
  }
  // Only the call whose turn it is may take what is free: one behind it that would fit waits
  // too, or a stream of small jobs could hold a large one back forever.
  while (!draining_ && !waiting_.empty()) {
    const auto it = NextLocked();
    Waiter* next = *it;
    if (!FitsLocked(*next)) {
      // A free slot but not the memory: the call keeps its turn until the memory is free, even
      // against hosts that arrive meanwhile and would rank before it.
      if (static_cast<int>(holders_.size()) < options_.max_concurrent_jobs) {
        waiting_for_memory_ = next;
      }
      break;
    }
    waiting_.erase(it);
    if (waiting_for_memory_ == next) waiting_for_memory_ = nullptr;
    reserved_bytes_ += next->reserve;
    next->holder = holders_.insert(holders_.end(), Holder{next->claim, next->reserve, next->host});
    hosts_[next->host].last_served = ++grants_;
    next->granted = true;
    granted = true;
  }
  if (granted) changed_.notify_all();
}

std::list<AdmissionQueue::Waiter*>::iterator AdmissionQueue::NextLocked() {
  if (waiting_for_memory_ != nullptr) {
    return std::find(waiting_.begin(), waiting_.end(), waiting_for_memory_);
  }
  // waiting_ is in arrival order, so the first call of the least recently served host is both
  // that host's oldest and, on a tie, the oldest host's. At most max_queued_jobs to look at.
  auto best = waiting_.begin();
  uint64_t best_served = hosts_.at((*best)->host).last_served;
  for (auto it = std::next(best); it != waiting_.end(); ++it) {
    const uint64_t served = hosts_.at((*it)->host).last_served;
    if (served < best_served) {
      best = it;
      best_served = served;
    }
  }
  return best;
}

void AdmissionQueue::AddCallLocked(const std::string& host) { ++hosts_[host].calls; }

void AdmissionQueue::EndCallLocked(const std::string& host) {
  const auto it = hosts_.find(host);
  if (--it->second.calls == 0) hosts_.erase(it);
}

void AdmissionQueue::Drain() {
  std::lock_guard lock(mu_);
  draining_ = true;
  changed_.notify_all();
}

int AdmissionQueue::in_flight() const {
  std::lock_guard lock(mu_);
  return static_cast<int>(holders_.size());
}

uint64_t AdmissionQueue::memory_reserved_bytes() const {
  std::lock_guard lock(mu_);
  return reserved_bytes_;
}

int AdmissionQueue::queued() const {
  std::lock_guard lock(mu_);
  return static_cast<int>(waiting_.size());
}

double AdmissionQueue::ExpectedWaitSeconds() const {
  std::lock_guard lock(mu_);
  return ExpectedWaitLocked();
}

double AdmissionQueue::ExpectedWaitLocked() const {
  return static_cast<double>(waiting_.size() + 1) * mean_hold_seconds_ /
         options_.max_concurrent_jobs;
}

void AdmissionQueue::PublishLocked() {
  observer_.AdmissionChanged(static_cast<int>(holders_.size()), static_cast<int>(waiting_.size()),
                             reserved_bytes_);
}

}  // namespace scanprep::server
