// SPDX-License-Identifier: Apache-2.0
// Admission control in front of the processing arena, in two steps. At its header a call takes
// a ticket: at most `max_concurrent_jobs + max_queued_jobs` calls hold one, and beyond that a call
// is refused at once (QUEUE_FULL), before the client sends anything large. With its ticket the
// call uploads, holding no processing slot, so a slow upload keeps no other job from running;
// once its data has arrived it waits for one of `max_concurrent_jobs` slots (TakeSlot). One
// client host (client_identity.h) may take every ticket and slot while nobody else waits; when
// hosts contend, a freed slot goes to the waiting host served least recently (its oldest call),
// so the hosts take turns instead of the one that queued most getting most, and with every ticket
// taken a host with fewer calls than another takes that host's newest ticket without a slot
// (DisplaceForLocked), so one that resubmits at once cannot keep the others out. A host with no
// ticket is forgotten, and counts as never served when it comes back.
//
// Each ticket also claims its job's estimated memory (memory_reservation.h), and the reservations
// never exceed `memory_capacity_bytes`. While uploading, a call reserves what its data holds so far
// plus one message ahead (Ticket::Reserve), so a large declaration that sends little holds little;
// it takes its slot only with all of its claim reserved, so a running job never waits for memory.
// A reservation is granted only when it leaves every ticket able to reserve the rest of its claim
// in some order, each returning all of it when done (the banker's algorithm for one resource), so
// calls waiting for each other's memory can never deadlock. The call whose turn it is is served
// first even when a smaller one behind it would fit, and keeps its turn while it waits for memory
// (no host's turn comes before it then), so a large job is not starved; only when the running
// jobs' memory would not make room for it do the calls waiting with it that fit go first, since
// what it needs is then theirs (their uploaded data). A job whose claim exceeds the whole
// capacity is refused at once.
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
  // One ticket: what its call claimed of the memory capacity and has reserved so far, and its
  // slot once it has one.
  struct Holder {
    uint64_t claim = 0;
    uint64_t reserved = 0;
    std::string host;
    bool processing = false;  // holds a slot
    absl::Time since;         // when it took its slot
    bool displaced = false;   // its ticket went to another host's call
  };

 public:
  // A call's admission; destroying it returns its reservation and its slot, if it took one, for
  // the next waiting call, and feeds the slot's hold time into the mean.
  class Ticket {
   public:
    Ticket(Ticket&& o) noexcept : queue_(std::exchange(o.queue_, nullptr)), holder_(o.holder_) {}
    Ticket& operator=(Ticket&&) = delete;
    ~Ticket();

    // Raises this call's reservation to `bytes` (at most its claim; a lower value changes
    // nothing), waiting while that is unsafe (see above). CANCELLED when `cancelled()` turns true
    // while waiting (polled); QUEUE_FULL once the ticket went to another host.
    absl::Status Reserve(uint64_t bytes, const std::function<bool()>& cancelled);
    // Waits for a slot with the whole claim reserved, in turn between hosts (see above). Fails as
    // Reserve does.
    absl::Status TakeSlot(const std::function<bool()>& cancelled);
    uint64_t claim_bytes() const;
    uint64_t reserved_bytes() const;

   private:
    friend class AdmissionQueue;
    Ticket(AdmissionQueue* queue, std::list<Holder>::iterator holder)
        : queue_(queue), holder_(holder) {}
    AdmissionQueue* queue_;
    std::list<Holder>::iterator holder_;
  };

  // A ticket for one call from client `host` claiming `claim_bytes` of the memory capacity, with
  // `reserve_bytes` of the claim reserved at once (waiting for them when taken). Fails at once with
  // RESOURCE_EXHAUSTED when the claim exceeds the whole capacity (JOB_EXCEEDS_MEMORY) or every
  // ticket is taken (QUEUE_FULL), DEADLINE_EXCEEDED when the call would have to wait for a slot
  // and the expected wait already exceeds `deadline`, UNAVAILABLE while draining, and as Reserve.
  absl::StatusOr<Ticket> Admit(const std::string& host, uint64_t claim_bytes,
                               uint64_t reserve_bytes, absl::Time deadline,
                               const std::function<bool()>& cancelled);

  // Refuse new calls; the calls already admitted go on (upload, wait for a slot, run), within
  // the server's grace period: each was sent to this replica and may hold its data.
  void Drain();

  int max_concurrent_jobs() const { return options_.max_concurrent_jobs; }
  int max_queued_jobs() const { return options_.max_queued_jobs; }
  uint64_t memory_capacity_bytes() const { return options_.memory_capacity_bytes; }
  uint64_t memory_reserved_bytes() const;
  int in_flight() const;  // slots held
  int queued() const;     // calls waiting for a slot after their upload
  int uploading() const;  // tickets neither waiting for a slot nor holding one
  // Seconds a call that asks for a slot now would wait at most: every waiting call plus itself,
  // each needing a slot to free up, at the running mean hold time shared by all slots (a call
  // from a host whose turn comes sooner waits less). 0 before any call ended.
  double ExpectedWaitSeconds() const;

 private:
  // A ticket waiting for a larger reservation, or for a slot and its whole claim.
  struct Waiter {
    std::list<Holder>::iterator holder;
    uint64_t reserve = 0;  // the reservation it waits to reach
    bool wants_slot = false;
    bool granted = false;
  };
  // A client host with tickets.
  struct Host {
    int calls = 0;
    uint64_t last_served = 0;  // grants_ when it was last granted a slot; 0 = not yet
  };
  void Release(std::list<Holder>::iterator holder);
  // Reserve, under the lock.
  absl::Status ReserveLocked(std::unique_lock<std::mutex>& lock, std::list<Holder>::iterator holder,
                             uint64_t bytes, const std::function<bool()>& cancelled);
  // QUEUE_FULL for a ticket that went to another host's call; OK otherwise.
  absl::Status DisplacedLocked(const Holder& holder) const;
  // Whether `waiter` can have what it waits for now: a free slot (when it wants one), and its
  // reservation within the capacity with every claim still able to finish.
  bool FitsLocked(const Waiter& waiter) const;
  // Whether every ticket could still reserve the rest of its claim, one after the other, once
  // `waiter` had what it waits for.
  bool SafeLocked(const Waiter& waiter) const;
  // Gives `waiter` what it waits for.
  void GrantToLocked(Waiter& waiter);
  // Whether `waiter` would fit once the jobs holding a slot have returned their memory.
  bool RunningJobsMakeRoomLocked(const Waiter& waiter) const;
  // The waiting call whose turn it is: the one kept waiting for memory, else the oldest call of
  // the host served least recently (the oldest such host's on a tie).
  std::list<Waiter*>::iterator NextLocked();
  // Grants every waiting reservation that fits, then slots to the waiting calls in turn while the
  // next one fits.
  void GrantLocked();
  // Counts a ticket of `host`; forgets a host with none left.
  void AddCallLocked(const std::string& host);
  void EndCallLocked(const std::string& host);
  // Waits until `self` is granted, its ticket is displaced or `cancelled()`.
  void WaitLocked(std::unique_lock<std::mutex>& lock, Waiter& self,
                  const std::function<bool()>& cancelled);
  double ExpectedWaitLocked() const;
  int UploadingLocked() const;
  // Max-min fair tickets: with every ticket taken, a call of `host` takes the newest ticket
  // without a slot of the host with the most tickets, when that host has at least two more than
  // `host`; true if it did. The displaced call ends QUEUE_FULL (at once when it waits, at its
  // next Reserve or TakeSlot when it uploads). So a host that floods the server keeps an equal
  // share once another host comes, and that host's call is first in turn for the next slot.
  bool DisplaceForLocked(const std::string& host);
  // RESOURCE_EXHAUSTED QUEUE_FULL, naming what holds the slots (and, when `displaced`, that the
  // call's ticket went to another host), with a RetryInfo.
  absl::Status QueueFullErrorLocked(bool displaced) const;
  // Reports the slots held, the calls waiting and uploading and the bytes reserved.
  void PublishLocked();

  AdmissionOptions options_;
  AdmissionObserver& observer_;
  mutable std::mutex mu_;
  std::condition_variable changed_;
  std::list<Holder> holders_;  // one per ticket, in the order they were taken
  int tickets_ = 0;            // holders not displaced
  int processing_ = 0;         // holders with a slot
  uint64_t reserved_bytes_ = 0;
  std::list<Waiter*> waiting_;  // calls waiting for a slot, arrival order
  std::map<std::string, Host> hosts_;
  uint64_t grants_ = 0;  // slots granted so far, the clock of Host::last_served
  // The call whose turn came while a slot was free but not the memory it needs: it keeps its turn.
  Waiter* waiting_for_memory_ = nullptr;
  std::list<Waiter*> growing_;  // tickets waiting for a larger reservation, arrival order
  double mean_hold_seconds_ = 0;
  bool have_mean_ = false;
  bool draining_ = false;
};

}  // namespace scanprep::server
