// SPDX-License-Identifier: Apache-2.0
#include "server/admission/memory_reservation.h"

#include <algorithm>
#include <atomic>
#include <fstream>
#include <sstream>

#include "absl/strings/ascii.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/base/status_macros.h"
#include "core/stages/neighbourhoods_stage.h"

namespace scanprep::server {
namespace {

std::optional<std::string> ReadFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) return std::nullopt;
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// MemTotal of /proc/meminfo in bytes; 0 when unreadable.
uint64_t MemTotal() {
  std::ifstream in("/proc/meminfo");
  std::string key, unit;
  uint64_t kib = 0;
  while (in >> key >> kib >> unit) {
    if (key == "MemTotal:") return kib * 1024;
  }
  return 0;
}

std::atomic<uint64_t> bytes_per_point_for_testing{0};

}  // namespace

void SetBytesPerPointForTesting(uint64_t bytes) { bytes_per_point_for_testing.store(bytes); }

uint64_t BaseBytesPerPoint() {
  const uint64_t hook = bytes_per_point_for_testing.load();
  return hook > 0 ? hook : kBytesPerPoint;
}

std::string FormatMiB(double bytes) { return absl::StrFormat("%.0f MiB", bytes / 1048576.0); }

uint64_t BytesPerPoint(const ParamOverrides& params) {
  // The k the job's plan will build its shared graph with (validated before admission).
  const int k = static_cast<int>(NeighbourhoodsParams().Read(params).k);
  return BaseBytesPerPoint() + kBytesPerPointPerExtraNeighbour *
                                   static_cast<uint64_t>(std::max(0, k - kDefaultNeighbours));
}

uint64_t EstimateJobBytes(uint64_t points, const ParamOverrides& params) {
  return kJobOverheadBytes + points * BytesPerPoint(params);
}

std::optional<uint64_t> ParseCgroupLimit(std::string_view text) {
  const absl::string_view trimmed =
      absl::StripAsciiWhitespace(absl::string_view(text.data(), text.size()));
  uint64_t bytes = 0;
  if (!absl::SimpleAtoi(trimmed, &bytes)) return std::nullopt;
  return bytes;
}

absl::StatusOr<MemoryCapacity> AutoMemoryCapacity(std::optional<uint64_t> container_limit,
                                                  uint64_t mem_total) {
  // cgroup v1 writes "no limit" as a huge page-aligned number; any limit not below the RAM is
  // no limit either.
  if (container_limit.has_value() && (mem_total == 0 || *container_limit < mem_total)) {
    if (*container_limit <= kServerOwnBytes) {
      return absl::FailedPreconditionError(
          absl::StrCat("the container's memory limit of ", FormatMiB(*container_limit),
                       " leaves nothing for jobs after the server's own ",
                       FormatMiB(kServerOwnBytes), "; raise the limit or set --memory_capacity"));
    }
    return MemoryCapacity{
        .bytes = *container_limit - kServerOwnBytes,
        .source = absl::StrCat("the container's memory limit ", FormatMiB(*container_limit),
                               " minus ", FormatMiB(kServerOwnBytes), " for the server")};
  }
  if (mem_total == 0) {
    return absl::FailedPreconditionError(
        "neither a container memory limit nor /proc/meminfo's MemTotal could be read; set "
        "--memory_capacity");
  }
  return MemoryCapacity{
      .bytes = static_cast<uint64_t>(kShareOfRam * static_cast<double>(mem_total)),
      .source = absl::StrCat(kShareOfRam * 100, " % of the machine's ", FormatMiB(mem_total),
                             " (no container memory limit)")};
}

absl::StatusOr<MemoryCapacity> DetectMemoryCapacity() {
  std::optional<uint64_t> limit;
  for (const char* path :
       {"/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"}) {
    if (const auto text = ReadFile(path)) {
      limit = ParseCgroupLimit(*text);  // "max" (v2, no limit) stays nullopt
      break;
    }
  }
  return AutoMemoryCapacity(limit, MemTotal());
}

uint64_t LargestJobPoints(uint64_t capacity_bytes) {
  return capacity_bytes > kJobOverheadBytes
             ? (capacity_bytes - kJobOverheadBytes) / BaseBytesPerPoint()
             : 0;
}

absl::StatusOr<MemoryLimits> ResolveMemoryLimits(uint64_t capacity_flag, uint64_t max_points_flag) {
  if (max_points_flag > kMaxIndexablePoints) {
    return absl::InvalidArgumentError(absl::StrCat("--max_points_per_job=", max_points_flag,
                                                   " is more than ", kMaxIndexablePoints,
                                                   ", the most points a job can index (32 bits)"));
  }
  SCANPREP_ASSIGN_OR_RETURN(const MemoryCapacity capacity,
                            capacity_flag > 0
                                ? absl::StatusOr<MemoryCapacity>(MemoryCapacity{
                                      .bytes = capacity_flag, .source = "--memory_capacity"})
                                : DetectMemoryCapacity());
  const uint64_t largest = LargestJobPoints(capacity.bytes);
  if (largest == 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("the memory capacity of ", capacity.bytes, " bytes (", capacity.source,
                     ") leaves no room for a job's fixed ", FormatMiB(kJobOverheadBytes),
                     "; raise --memory_capacity"));
  }
  if (max_points_flag == 0) {
    return MemoryLimits{.capacity = capacity,
                        .max_points_per_job = std::min(kDefaultMaxPointsPerJob, largest)};
  }
  if (max_points_flag > largest) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--max_points_per_job=", max_points_flag, " needs an estimated ",
        FormatMiB(kJobOverheadBytes + static_cast<double>(max_points_flag) * BaseBytesPerPoint()),
        " (", FormatMiB(kJobOverheadBytes), " + ", BaseBytesPerPoint(),
        " B/point), more than the memory capacity of ", FormatMiB(capacity.bytes), " (",
        capacity.source, "): such a job could never run; lower --max_points_per_job to at most ",
        largest, " or raise --memory_capacity"));
  }
  return MemoryLimits{.capacity = capacity, .max_points_per_job = max_points_flag};
}

}  // namespace scanprep::server
