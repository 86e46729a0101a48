// SPDX-License-Identifier: Apache-2.0
#include "server/admission.h"

#include "server/error_details.h"
#include "server/memory_budget.h"

#include <algorithm>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace scanprep::server {
namespace {

// How often a waiting call looks at its cancellation (client gone or deadline passed).
constexpr std::chrono::milliseconds kPollInterval(25);

absl::Status DrainingError() {
  return WithReason(absl::UnavailableError("the server is shutting down (draining) and takes no "
                                           "new jobs; retry on another replica"),
                    "SHUTTING_DOWN", kRetryOnAnotherReplica);
}

}  // namespace

AdmissionQueue::AdmissionQueue(AdmissionOptions options, ServiceMetrics& metrics)
    : options_(std::move(options)), metrics_(metrics) {
  metrics_.SetQueueCapacity(options_.max_queued_jobs);
  metrics_.SetMemoryBudget(options_.memory_budget_bytes);
  PublishLocked();
}

AdmissionQueue::Slot::~Slot() {
  if (queue_ != nullptr) queue_->Release(since_, bytes_);
}

absl::StatusOr<AdmissionQueue::Slot> AdmissionQueue::Admit(uint64_t bytes, absl::Time deadline,
                                                           const std::function<bool()>& cancelled) {
  const absl::Time arrived = options_.now();
  std::unique_lock lock(mu_);
  if (draining_) {
    metrics_.Rejected(RejectReason::kDraining);
    return DrainingError();
  }
  if (bytes > options_.memory_budget_bytes) {
    metrics_.Rejected(RejectReason::kMemory);
    absl::Status refused = WithReason(
        absl::ResourceExhaustedError(absl::StrCat(
            "the job's estimated memory of ", FormatMiB(bytes), " (", bytes,
            " bytes, from header.total_points) exceeds the server's whole memory budget of ",
            FormatMiB(options_.memory_budget_bytes), " (", options_.memory_budget_bytes,
            " bytes, memory_budget), so it could never run here; send fewer points per job or "
            "raise the server's --memory_budget")),
        "JOB_EXCEEDS_MEMORY");
    refused = WithMetadata(std::move(refused), "estimate_bytes", absl::StrCat(bytes));
    return WithMetadata(std::move(refused), "budget_bytes",
                        absl::StrCat(options_.memory_budget_bytes));
  }
  if (waiting_.empty() && FitsLocked(bytes)) {
    ++in_flight_;
    reserved_bytes_ += bytes;
    PublishLocked();
    metrics_.PhaseEnded(Phase::kQueue, 0);
    return Slot(this, arrived, bytes);
  }
  if (static_cast<int>(waiting_.size()) >= options_.max_queued_jobs) {
    metrics_.Rejected(RejectReason::kQueueFull);
    // Retry once the queue can be expected to have moved; at least a second, so that refused
    // clients do not hammer a server that has not finished a job yet.
    return WithReason(
        absl::ResourceExhaustedError(absl::StrCat(
            in_flight_ >= options_.max_concurrent_jobs
                ? absl::StrCat("the server is running its limit of ", options_.max_concurrent_jobs,
                               " concurrent jobs (max_concurrent_jobs)")
                : absl::StrCat("the server's ", in_flight_, " running jobs hold ",
                               FormatMiB(reserved_bytes_), " of its ",
                               FormatMiB(options_.memory_budget_bytes),
                               " memory budget (memory_budget)"),
            " and its queue of ", options_.max_queued_jobs,
            " waiting jobs (max_queued_jobs) is full; retry later or on another replica")),
        "QUEUE_FULL", absl::Seconds(std::max(1.0, ExpectedWaitLocked())));
  }
  const double expected = ExpectedWaitLocked();
  const double remaining = absl::ToDoubleSeconds(deadline - arrived);
  if (expected > remaining) {
    metrics_.Rejected(RejectReason::kDeadline);
    return absl::DeadlineExceededError(absl::StrFormat(
        "expected wait %.3g s exceeds the deadline %.3g s (%d jobs queued, mean job time %.3g s)",
        expected, std::max(0.0, remaining), static_cast<int>(waiting_.size()), mean_hold_seconds_));
  }

  Waiter self{.bytes = bytes};
  const auto position = waiting_.insert(waiting_.end(), &self);
  PublishLocked();
  while (!self.granted && !draining_) {
    if (changed_.wait_for(lock, kPollInterval, [&] { return self.granted || draining_; })) break;
    if (cancelled()) break;
  }
  if (self.granted) {  // GrantLocked already moved it from the queue to a slot
    metrics_.PhaseEnded(Phase::kQueue, absl::ToDoubleSeconds(options_.now() - arrived));
    return Slot(this, options_.now(), bytes);
  }
  waiting_.erase(position);
  GrantLocked();  // the calls behind it may fit now
  PublishLocked();
  if (draining_) {
    metrics_.Rejected(RejectReason::kDraining);
    return DrainingError();
  }
  return absl::CancelledError("the call was cancelled or its deadline passed while queued");
}

void AdmissionQueue::Release(absl::Time since, uint64_t bytes) {
  const double held = absl::ToDoubleSeconds(options_.now() - since);
  std::lock_guard lock(mu_);
  mean_hold_seconds_ =
      have_mean_ ? (1 - options_.mean_weight) * mean_hold_seconds_ + options_.mean_weight * held
                 : held;
  have_mean_ = true;
  --in_flight_;
  reserved_bytes_ -= bytes;
  GrantLocked();
  PublishLocked();
}

bool AdmissionQueue::FitsLocked(uint64_t bytes) const {
  return in_flight_ < options_.max_concurrent_jobs &&
         bytes <= options_.memory_budget_bytes - reserved_bytes_;
}

void AdmissionQueue::GrantLocked() {
  if (draining_) return;
  bool granted = false;
  // Only the oldest call may take what is free: one behind it that would fit waits too, or a
  // stream of small jobs could hold a large one back forever.
  while (!waiting_.empty() && FitsLocked(waiting_.front()->bytes)) {
    Waiter* next = waiting_.front();
    waiting_.pop_front();
    next->granted = true;
    ++in_flight_;
    reserved_bytes_ += next->bytes;
    granted = true;
  }
  if (granted) changed_.notify_all();
}

void AdmissionQueue::Drain() {
  std::lock_guard lock(mu_);
  draining_ = true;
  changed_.notify_all();
}

int AdmissionQueue::in_flight() const {
  std::lock_guard lock(mu_);
  return in_flight_;
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
  metrics_.SetAdmissionState(in_flight_, static_cast<int>(waiting_.size()));
  metrics_.SetMemoryReserved(reserved_bytes_);
}

}  // namespace scanprep::server
