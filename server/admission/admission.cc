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

AdmissionQueue::Ticket::~Ticket() {
  if (queue_ != nullptr) queue_->Release(holder_);
}

uint64_t AdmissionQueue::Ticket::claim_bytes() const {
  std::lock_guard lock(queue_->mu_);
  return holder_->claim;
}

uint64_t AdmissionQueue::Ticket::reserved_bytes() const {
  std::lock_guard lock(queue_->mu_);
  return holder_->reserved;
}

absl::Status AdmissionQueue::Ticket::Reserve(uint64_t bytes,
                                             const std::function<bool()>& cancelled) {
  std::unique_lock lock(queue_->mu_);
  return queue_->ReserveLocked(lock, holder_, bytes, cancelled);
}

absl::Status AdmissionQueue::ReserveLocked(std::unique_lock<std::mutex>& lock,
                                           std::list<Holder>::iterator holder, uint64_t bytes,
                                           const std::function<bool()>& cancelled) {
  if (absl::Status ended = DisplacedLocked(*holder); !ended.ok()) return ended;
  Waiter self{.holder = holder, .reserve = std::min(bytes, holder->claim)};
  if (self.reserve <= holder->reserved) return absl::OkStatus();
  if (FitsLocked(self)) {  // any safe reservation may go first (GrantLocked)
    GrantToLocked(self);
    PublishLocked();
    return absl::OkStatus();
  }
  const auto position = growing_.insert(growing_.end(), &self);
  WaitLocked(lock, self, cancelled);
  if (self.granted) return absl::OkStatus();         // GrantLocked took it off the list
  if (!holder->displaced) growing_.erase(position);  // else DisplaceForLocked did
  GrantLocked();                                     // the reservations behind it may be safe now
  PublishLocked();
  if (absl::Status ended = DisplacedLocked(*holder); !ended.ok()) return ended;
  return absl::CancelledError(
      "the call was cancelled or its deadline passed while it waited for memory");
}

absl::Status AdmissionQueue::Ticket::TakeSlot(const std::function<bool()>& cancelled) {
  AdmissionQueue& q = *queue_;
  const absl::Time arrived = q.options_.now();
  std::unique_lock lock(q.mu_);
  if (absl::Status ended = q.DisplacedLocked(*holder_); !ended.ok()) return ended;
  Waiter self{.holder = holder_, .reserve = holder_->claim, .wants_slot = true};
  if (q.waiting_.empty() && q.FitsLocked(self)) {
    q.GrantToLocked(self);
    q.PublishLocked();
    q.observer_.Admitted(0);
    return absl::OkStatus();
  }
  const auto position = q.waiting_.insert(q.waiting_.end(), &self);
  q.GrantLocked();  // its turn may come before the calls that could not go (a host's first)
  q.PublishLocked();
  q.WaitLocked(lock, self, cancelled);
  if (self.granted) {  // GrantLocked already moved it from the queue to a slot
    q.observer_.Admitted(absl::ToDoubleSeconds(q.options_.now() - arrived));
    return absl::OkStatus();
  }
  if (!holder_->displaced) q.waiting_.erase(position);  // DisplaceForLocked took it off
  if (q.waiting_for_memory_ == &self) q.waiting_for_memory_ = nullptr;
  q.GrantLocked();  // the calls behind it may fit now
  q.PublishLocked();
  if (absl::Status ended = q.DisplacedLocked(*holder_); !ended.ok()) return ended;
  return absl::CancelledError("the call was cancelled or its deadline passed while queued");
}

absl::Status AdmissionQueue::DisplacedLocked(const Holder& holder) const {
  if (!holder.displaced) return absl::OkStatus();
  observer_.Refused(AdmissionRefusal::kQueueFull);
  return QueueFullErrorLocked(/*displaced=*/true);
}

absl::StatusOr<AdmissionQueue::Ticket> AdmissionQueue::Admit(
    const std::string& host, uint64_t claim_bytes, uint64_t reserve_bytes, absl::Time deadline,
    const std::function<bool()>& cancelled) {
  std::unique_lock lock(mu_);
  if (draining_) {
    observer_.Refused(AdmissionRefusal::kDraining);
    return DrainingError();
  }
  if (claim_bytes > options_.memory_capacity_bytes) {
    observer_.Refused(AdmissionRefusal::kMemory);
    return ExceedsCapacityError(claim_bytes, options_.memory_capacity_bytes);
  }
  // Only a call that would wait for a slot is held to its deadline here: one that finds a slot
  // free, or a ticket uploading ahead of it, is not.
  const bool slot_free = waiting_.empty() && processing_ < options_.max_concurrent_jobs;
  const double expected = slot_free ? 0 : ExpectedWaitLocked();
  const double remaining = absl::ToDoubleSeconds(deadline - options_.now());
  // A call that would be refused for its deadline anyway displaces nobody.
  if (tickets_ >= options_.max_concurrent_jobs + options_.max_queued_jobs &&
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
  const auto holder = holders_.insert(holders_.end(), Holder{.claim = claim_bytes, .host = host});
  ++tickets_;
  AddCallLocked(host);
  PublishLocked();
  Ticket ticket(this, holder);
  const absl::Status reserved = ReserveLocked(lock, holder, reserve_bytes, cancelled);
  lock.unlock();                        // the ticket's destructor takes the lock
  if (!reserved.ok()) return reserved;  // and returns what it took
  return ticket;
}

bool AdmissionQueue::DisplaceForLocked(const std::string& host) {
  const auto mine = hosts_.find(host);
  int most = (mine == hosts_.end() ? 0 : mine->second.calls) + 1;
  auto victim = holders_.rend();
  for (auto it = holders_.rbegin(); it != holders_.rend(); ++it) {  // newest first
    // A call with a slot keeps it, and the one kept waiting for memory keeps its turn.
    if (it->processing || it->displaced ||
        (waiting_for_memory_ != nullptr && waiting_for_memory_->holder == std::next(it).base())) {
      continue;
    }
    const int calls = hosts_.at(it->host).calls;
    if (calls > most) {
      most = calls;
      victim = it;
    }
  }
  if (victim == holders_.rend()) return false;
  const auto displaced = std::next(victim).base();
  displaced->displaced = true;
  --tickets_;
  EndCallLocked(displaced->host);
  const auto of_victim = [&](const Waiter* w) { return w->holder == displaced; };
  waiting_.remove_if(of_victim);
  growing_.remove_if(of_victim);
  changed_.notify_all();
  return true;
}

absl::Status AdmissionQueue::QueueFullErrorLocked(bool displaced) const {
  const int queued = static_cast<int>(waiting_.size());
  // Retry once the queue can be expected to have moved; at least a second, so that refused
  // clients do not hammer a server that has not finished a job yet.
  return WithReason(
      absl::ResourceExhaustedError(absl::StrCat(
          displaced ? "this call's place in the queue went to a call of another client host, "
                      "which held or awaited fewer jobs than yours (hosts keep equal shares of "
                      "the queue when they contend): "
                    : "",
          "the server holds its limit of ", options_.max_concurrent_jobs + options_.max_queued_jobs,
          " jobs (max_concurrent_jobs ", options_.max_concurrent_jobs, " + max_queued_jobs ",
          options_.max_queued_jobs, "): ", processing_, " running, ", queued,
          " waiting for a slot, ", UploadingLocked(), " uploading",
          processing_ < options_.max_concurrent_jobs && queued > 0
              ? absl::StrCat(", the jobs reserving ", FormatMiB(reserved_bytes_), " of its ",
                             FormatMiB(options_.memory_capacity_bytes),
                             " memory capacity (memory_capacity)")
              : "",
          "; the queue is full, retry later or on another replica")),
      "QUEUE_FULL", absl::Seconds(std::max(1.0, ExpectedWaitLocked())));
}

void AdmissionQueue::WaitLocked(std::unique_lock<std::mutex>& lock, Waiter& self,
                                const std::function<bool()>& cancelled) {
  const auto done = [&] { return self.granted || self.holder->displaced; };
  while (!done()) {
    if (changed_.wait_for(lock, kPollInterval, done)) break;
    if (cancelled()) break;
  }
}

void AdmissionQueue::Release(std::list<Holder>::iterator holder) {
  const absl::Time now = options_.now();
  std::lock_guard lock(mu_);
  if (holder->processing) {
    const double held = absl::ToDoubleSeconds(now - holder->since);
    mean_hold_seconds_ =
        have_mean_ ? (1 - options_.mean_weight) * mean_hold_seconds_ + options_.mean_weight * held
                   : held;
    have_mean_ = true;
    --processing_;
  }
  reserved_bytes_ -= holder->reserved;
  if (!holder->displaced) {  // DisplaceForLocked already ended its call
    --tickets_;
    EndCallLocked(holder->host);
  }
  holders_.erase(holder);
  GrantLocked();
  PublishLocked();
}

bool AdmissionQueue::FitsLocked(const Waiter& waiter) const {
  if (waiter.wants_slot && processing_ >= options_.max_concurrent_jobs) return false;
  const uint64_t extra = waiter.reserve - waiter.holder->reserved;
  return extra <= options_.memory_capacity_bytes - reserved_bytes_ && SafeLocked(waiter);
}

bool AdmissionQueue::SafeLocked(const Waiter& waiter) const {
  // What each ticket still needs and what it returns when done, with the waiter's request in
  // place. Served smallest need first: if any order lets every ticket finish, that one does (the
  // free bytes only grow as tickets finish). A displaced ticket needs nothing more.
  struct Claim {
    uint64_t need;
    uint64_t reserved;
  };
  std::vector<Claim> claims;
  claims.reserve(holders_.size());
  uint64_t reserved = 0;
  for (auto it = holders_.begin(); it != holders_.end(); ++it) {
    const uint64_t r = it == waiter.holder ? waiter.reserve : it->reserved;
    claims.push_back({it->displaced ? 0 : it->claim - r, r});
    reserved += r;
  }
  std::sort(claims.begin(), claims.end(),
            [](const Claim& a, const Claim& b) { return a.need < b.need; });
  uint64_t free = options_.memory_capacity_bytes - reserved;
  for (const Claim& c : claims) {
    if (c.need > free) return false;
    free += c.reserved;
  }
  return true;
}

void AdmissionQueue::GrantToLocked(Waiter& waiter) {
  Holder& holder = *waiter.holder;
  reserved_bytes_ += waiter.reserve - holder.reserved;
  holder.reserved = waiter.reserve;
  if (waiter.wants_slot) {
    holder.processing = true;
    holder.since = options_.now();
    ++processing_;
    hosts_[holder.host].last_served = ++grants_;
  }
  waiter.granted = true;
}

void AdmissionQueue::GrantLocked() {
  bool granted = false;
  // Reservations first, any that is safe: their tickets take slots once their claims are
  // complete, and free everything when done.
  for (auto it = growing_.begin(); it != growing_.end();) {
    if (!FitsLocked(**it)) {
      ++it;
      continue;
    }
    GrantToLocked(**it);
    it = growing_.erase(it);
    granted = true;
  }
  // Only the call whose turn it is may take what is free: one behind it that would fit waits
  // too, or a stream of small jobs could hold a large one back forever.
  while (!waiting_.empty()) {
    const auto it = NextLocked();
    Waiter* next = *it;
    if (processing_ >= options_.max_concurrent_jobs) break;
    if (!FitsLocked(*next)) {
      // A free slot but not the memory: the call keeps its turn until the memory is free, even
      // against hosts that arrive meanwhile and would rank before it, as long as the running
      // jobs' memory would be enough. Beyond that only the calls waiting with it hold what it
      // needs, and they cannot run before it: the first of them that fits goes, or they would
      // all wait for each other.
      waiting_for_memory_ = next;
      if (RunningJobsMakeRoomLocked(*next)) break;
      const auto other = std::find_if(waiting_.begin(), waiting_.end(),
                                      [&](const Waiter* w) { return w != next && FitsLocked(*w); });
      if (other == waiting_.end()) break;
      GrantToLocked(**other);
      waiting_.erase(other);
      granted = true;
      continue;
    }
    waiting_.erase(it);
    if (waiting_for_memory_ == next) waiting_for_memory_ = nullptr;
    GrantToLocked(*next);
    granted = true;
  }
  if (granted) changed_.notify_all();
}

bool AdmissionQueue::RunningJobsMakeRoomLocked(const Waiter& waiter) const {
  uint64_t room = options_.memory_capacity_bytes - reserved_bytes_;
  for (const Holder& h : holders_) room += h.processing ? h.reserved : 0;
  return waiter.reserve - waiter.holder->reserved <= room;
}

std::list<AdmissionQueue::Waiter*>::iterator AdmissionQueue::NextLocked() {
  if (waiting_for_memory_ != nullptr) {
    return std::find(waiting_.begin(), waiting_.end(), waiting_for_memory_);
  }
  // waiting_ is in arrival order, so the first call of the least recently served host is both
  // that host's oldest and, on a tie, the oldest host's. At most every ticket to look at.
  auto best = waiting_.begin();
  uint64_t best_served = hosts_.at((*best)->holder->host).last_served;
  for (auto it = std::next(best); it != waiting_.end(); ++it) {
    const uint64_t served = hosts_.at((*it)->holder->host).last_served;
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
  return processing_;
}

uint64_t AdmissionQueue::memory_reserved_bytes() const {
  std::lock_guard lock(mu_);
  return reserved_bytes_;
}

int AdmissionQueue::queued() const {
  std::lock_guard lock(mu_);
  return static_cast<int>(waiting_.size());
}

int AdmissionQueue::uploading() const {
  std::lock_guard lock(mu_);
  return UploadingLocked();
}

int AdmissionQueue::UploadingLocked() const {
  return tickets_ - processing_ - static_cast<int>(waiting_.size());
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
  observer_.AdmissionChanged(processing_, static_cast<int>(waiting_.size()), UploadingLocked(),
                             reserved_bytes_);
}

}  // namespace scanprep::server
