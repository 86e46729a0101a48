// SPDX-License-Identifier: Apache-2.0
#include "server/admission/memory_guard.h"

#include <fcntl.h>
#include <unistd.h>

#include <vector>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "absl/time/time.h"
#include "server/admission/memory_reservation.h"
#include "wire/error_details.h"

// GCC says __SANITIZE_ADDRESS__ / __SANITIZE_THREAD__, clang __has_feature(...).
#if defined(__has_feature)
#if __has_feature(address_sanitizer)
#define SCANPREP_SANITIZER_IN_RSS "AddressSanitizer"
#elif __has_feature(thread_sanitizer)
#define SCANPREP_SANITIZER_IN_RSS "ThreadSanitizer"
#endif
#endif
#ifndef SCANPREP_SANITIZER_IN_RSS
#if defined(__SANITIZE_ADDRESS__)
#define SCANPREP_SANITIZER_IN_RSS "AddressSanitizer"
#elif defined(__SANITIZE_THREAD__)
#define SCANPREP_SANITIZER_IN_RSS "ThreadSanitizer"
#else
#define SCANPREP_SANITIZER_IN_RSS ""
#endif
#endif

namespace scanprep::server {
namespace {

absl::Status ReservationExceeded(uint64_t used, uint64_t reserved, const RunningJob& job,
                                 size_t processing) {
  absl::Status status = absl::ResourceExhaustedError(absl::StrCat(
      "the job took more memory than it reserved: the server's resident memory reached ",
      FormatMiB(used), " above its idle baseline, more than the ", FormatMiB(reserved),
      " reserved by the admitted jobs plus ", FormatMiB(kMemoryGuardTripBytes),
      " (a quarter of the memory guard's margin of ", FormatMiB(kMemoryGuardMarginBytes),
      "); this job reserved ", FormatMiB(job.reservation_bytes()),
      " estimated from its point count",
      processing > 1 ? absl::StrCat(" and started last of the ", processing, " jobs processing")
                     : "",
      "; its input needs more memory per point than the estimate allows: send fewer points per "
      "job"));
  status = WithReason(std::move(status), "MEMORY_RESERVATION_EXCEEDED");
  status =
      WithMetadata(std::move(status), "reservation_bytes", absl::StrCat(job.reservation_bytes()));
  status = WithMetadata(std::move(status), "used_bytes", absl::StrCat(used));
  status = WithMetadata(std::move(status), "reserved_bytes", absl::StrCat(reserved));
  return WithMetadata(std::move(status), "margin_bytes", absl::StrCat(kMemoryGuardMarginBytes));
}

}  // namespace

std::optional<uint64_t> ResidentBytes() {
  // Read with plain syscalls: this runs every 10 ms.
  const int fd = open("/proc/self/statm", O_RDONLY | O_CLOEXEC);
  if (fd < 0) return std::nullopt;
  char text[128];
  const ssize_t n = read(fd, text, sizeof(text) - 1);
  close(fd);
  if (n <= 0) return std::nullopt;
  // "size resident shared text lib data dt", in pages.
  const std::vector<absl::string_view> fields =
      absl::StrSplit(absl::string_view(text, static_cast<size_t>(n)), ' ');
  uint64_t pages = 0;
  if (fields.size() < 2 || !absl::SimpleAtoi(fields[1], &pages)) return std::nullopt;
  return pages * static_cast<uint64_t>(sysconf(_SC_PAGESIZE));
}

std::string SanitizerInResidentMemory() { return SCANPREP_SANITIZER_IN_RSS; }

MemoryGuard::MemoryGuard(MemoryGuardOptions options, const AdmissionQueue& admission,
                         JobRunner& runner, AdmissionObserver& observer, CallLog& log)
    : options_(std::move(options)),
      admission_(admission),
      runner_(runner),
      observer_(observer),
      log_(log) {
  if (!options_.enabled) return;
  // A sanitizer's shadow memory and (ASan) quarantine of freed blocks are resident and no job's:
  // the guard would end jobs for memory they never held. (A test's own memory source still runs.)
  if (const std::string sanitizer = SanitizerInResidentMemory();
      !sanitizer.empty() && !options_.resident_bytes) {
    log_.Write(CallLog::kInfo, absl::StrCat("memory guard off: built with ", sanitizer,
                                            ", whose own memory is part of the resident set"));
    return;
  }
  if (!options_.resident_bytes) options_.resident_bytes = ResidentBytes;
  // The server serves no call yet: this is its idle memory.
  baseline_ = options_.resident_bytes();
  if (!baseline_.has_value()) {
    log_.Write(CallLog::kWarning, "memory guard off: /proc/self/statm is unreadable");
    return;
  }
  log_.Write(CallLog::kInfo,
             absl::StrCat("memory guard on: a job in processing ends once the resident memory "
                          "above the idle baseline exceeds the reservations by ",
                          FormatMiB(kMemoryGuardTripBytes), " (sampled every ",
                          kMemoryGuardPeriodMs, " ms)"));
  thread_ = std::thread([this] { Watch(); });
}

MemoryGuard::~MemoryGuard() {
  stop_.Notify();
  if (thread_.joinable()) thread_.join();
}

void MemoryGuard::Watch() {
  while (!stop_.WaitForNotificationWithTimeout(absl::Milliseconds(kMemoryGuardPeriodMs))) {
    Sample();
  }
}

void MemoryGuard::Sample() {
  const std::optional<uint64_t> resident = options_.resident_bytes();
  if (!resident.has_value()) return;
  const uint64_t reserved = admission_.memory_reserved_bytes();
  if (reserved == 0) {
    baseline_ = *resident;
    return;
  }
  if (!baseline_.has_value() || *resident <= *baseline_ + reserved + kMemoryGuardTripBytes) return;
  // One job at a time: the one ended last frees its stages' memory once it has stopped.
  if (const auto previous = ending_.lock(); previous != nullptr && !previous->done()) return;
  const std::vector<std::shared_ptr<RunningJob>> processing = runner_.Processing();
  if (processing.empty()) return;
  const std::shared_ptr<RunningJob>& newest = processing.back();
  newest->End(ReservationExceeded(*resident - *baseline_, reserved, *newest, processing.size()));
  ending_ = newest;
  observer_.MemoryGuardTripped();
}

}  // namespace scanprep::server
