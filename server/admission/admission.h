// SPDX-License-Identifier: Apache-2.0
// Admission control in front of the processing arena: at most `max_concurrent_jobs` calls hold a
// slot, up to `max_queued_jobs` more wait for one, and anything beyond that is refused at once.
// One client host (client_identity.h) may take every slot and queue place while nobody else
// waits; when hosts contend, a freed slot goes to the waiting host served least recently (its
// oldest call), so the hosts take turns instead of the one that queued most getting most, and a
// full queue gives a place to a host with fewer calls than another by taking that host's newest
// waiting call (DisplaceForLocked), so one that resubmits at once cannot keep the others out. A
// host with no call held or waiting is forgotten, and counts as never served when it comes back. A
// call is admitted when its header arrives, before the upload: a waiting call holds no points, so
// memory stays bounded by the running jobs, and a full server refuses before the client sends
// anything large.
//
// Each call also claims its job's estimated memory (memory_reservation.h), and the reservations
// never exceed `memory_capacity_bytes`. A claim is reserved as the job's data arrives
// (Slot::Reserve), so a large declaration that sends little holds little; a job runs only once all
// of its claim is reserved. A reservation is granted only when it leaves every holder able to
// reserve the rest of its claim in some order, each returning all of it when done (the banker's
// algorithm for one resource), so slot holders waiting for each other's memory can never deadlock.
// A call waits until both a slot and the bytes it reserves at once are free; the call whose turn it
// is is served first even when a smaller one behind it would fit, and keeps its turn while it waits
// for memory (no host's turn comes before it then), so a large job is not starved; a job whose
// claim exceeds the whole capacity is refused at once.
#pragma once

#include <condition_variable>
#include <functional>
#include <limits>
#include <list>
#include <map>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "server/admission/admission_observer.h"

namespace scanprep::server {

struct AdmissionOptions {
  int max_concurrent_jobs = 4;
  int max_queued_jobs = 8;
  // Sum of the reservations of the calls holding a slot; the default is no limit.
  uint64_t memory_capacity_bytes = std::numeric_limits<uint64_t>::max();
  // Weight of the newest job in the running mean of slot hold times.
  double mean_weight = 0.3;
  // Time source, replaceable in tests.
  std::function<absl::Time()> now = absl::Now;
};

class AdmissionQueue {
 public:
  // Reports to `observer`, which must outlive it.
  AdmissionQueue(AdmissionOptions options, AdmissionObserver& observer);

 private:
  // What one slot holder claimed of the memory capacity and has reserved so far.
  struct Holder {
    uint64_t claim = 0;
    uint64_t reserved = 0;
    std::string host;
  };

 public:
  // A held slot; destroying it frees the slot and its reservation for the next waiting call and
  // feeds its hold time into the mean.
  class Slot {
   public:
    Slot(Slot&& o) noexcept
        : queue_(std::exchange(o.queue_, nullptr)), since_(o.since_), holder_(o.holder_) {}
    Slot& operator=(Slot&&) = delete;
    ~Slot();

    // Raises this call's reservation to `bytes` (at most its claim; a lower value changes
    // nothing), waiting while that is unsafe (see above). CANCELLED when `cancelled()` turns true
    // while waiting (polled).
    absl::Status Reserve(uint64_t bytes, const std::function<bool()>& cancelled);
    uint64_t claim_bytes() const;
    uint64_t reserved_bytes() const;

   private:
    friend class AdmissionQueue;
    Slot(AdmissionQueue* queue, absl::Time since, std::list<Holder>::iterator holder)
        : queue_(queue), since_(since), holder_(holder) {}
    AdmissionQueue* queue_;
    absl::Time since_;
    std::list<Holder>::iterator holder_;
  };

  // A slot for one call from client `host` claiming `claim_bytes` of the memory capacity, with
  // `reserve_bytes` of the claim reserved at once (Slot::Reserve the rest), waiting for them when
  // taken. Fails at once with RESOURCE_EXHAUSTED when the claim exceeds the whole capacity
  // (JOB_EXCEEDS_MEMORY) or the queue is full (QUEUE_FULL), DEADLINE_EXCEEDED when the expected
  // wait already exceeds `deadline`, UNAVAILABLE while draining (also for calls still waiting when
  // the drain starts), and CANCELLED when `cancelled()` turns true while waiting (polled).
  absl::StatusOr<Slot> Admit(const std::string& host, uint64_t claim_bytes, uint64_t reserve_bytes,
                             absl::Time deadline, const std::function<bool()>& cancelled);

  // Refuse new calls and release the waiting ones with UNAVAILABLE; slots held stay valid.
  void Drain();

  int max_concurrent_jobs() const { return options_.max_concurrent_jobs; }
  int max_queued_jobs() const { return options_.max_queued_jobs; }
  uint64_t memory_capacity_bytes() const { return options_.memory_capacity_bytes; }
  uint64_t memory_reserved_bytes() const;
  int in_flight() const;  // slots held
  int queued() const;
  // Seconds a newly queued call would wait at most: every waiting call plus itself, each needing
  // a slot to free up, at the running mean hold time shared by all slots (a call from a host
  // whose turn comes sooner waits less). 0 before any call ended.
  double ExpectedWaitSeconds() const;

 private:
  // A call waiting for a slot, or a holder waiting for more of its claim.
  struct Waiter {
    uint64_t claim = 0;
    uint64_t reserve = 0;  // the reservation it waits to reach
    bool holds_slot = false;
    std::list<Holder>::iterator holder;  // when holds_slot, or once granted a slot
    bool granted = false;
    bool displaced = false;  // its queue place went to another host's call
    std::string host;        // of a call waiting for a slot
  };
  // A client host with calls holding or waiting for a slot.
  struct Host {
    int calls = 0;
    uint64_t last_served = 0;  // grants_ when it was last granted a slot; 0 = not yet
  };
  void Release(absl::Time since, std::list<Holder>::iterator holder);
  // Whether `waiter` can have what it waits for now: a free slot (for a new call), and its
  // reservation within the capacity with every claim still able to finish.
  bool FitsLocked(const Waiter& waiter) const;
  // Whether every holder could still reserve the rest of its claim, one after the other, once
  // `waiter` had what it waits for.
  bool SafeLocked(const Waiter& waiter) const;
  // The waiting call whose turn it is: the one kept waiting for memory, else the oldest call of
  // the host served least recently (the oldest such host's on a tie).
  std::list<Waiter*>::iterator NextLocked();
  // Grants every waiting reservation that fits, then slots to the waiting calls in turn while the
  // next one fits.
  void GrantLocked();
  // Counts a call of `host` that holds or waits for a slot; forgets a host with none left.
  void AddCallLocked(const std::string& host);
  void EndCallLocked(const std::string& host);
  // Waits until `self` is granted, the drain starts (slot waiters only) or `cancelled()`.
  void WaitLocked(std::unique_lock<std::mutex>& lock, Waiter& self,
                  const std::function<bool()>& cancelled);
  double ExpectedWaitLocked() const;
  // Max-min fair queue places: with the queue full, a call of `host` takes the place of the newest
  // waiting call of the host with the most calls (held or waiting), when that host has at least
  // two more than `host`; true if it did. The displaced call ends QUEUE_FULL. So a host that
  // floods the server keeps an equal share once another host comes, and that host's call is
  // first in turn for the next slot.
  bool DisplaceForLocked(const std::string& host);
  // RESOURCE_EXHAUSTED QUEUE_FULL, naming what holds the slots (and, when `displaced`, that the
  // call's place went to another host), with a RetryInfo.
  absl::Status QueueFullErrorLocked(bool displaced) const;
  // Reports the slots held, the calls waiting and the bytes reserved.
  void PublishLocked();

  AdmissionOptions options_;
  AdmissionObserver& observer_;
  mutable std::mutex mu_;
  std::condition_variable changed_;
  std::list<Holder> holders_;  // one per slot held
  uint64_t reserved_bytes_ = 0;
  std::list<Waiter*> waiting_;  // calls waiting for a slot, arrival order
  std::map<std::string, Host> hosts_;
  uint64_t grants_ = 0;  // slots granted so far, the clock of Host::last_served
  // The call whose turn came while a slot was free but not the memory it needs: it keeps its turn.
  Waiter* waiting_for_memory_ = nullptr;
  std::list<Waiter*> growing_;  // holders waiting for more of their claim, arrival order
  double mean_hold_seconds_ = 0;
  bool have_mean_ = false;
  bool draining_ = false;
};

}  // namespace scanprep::server
