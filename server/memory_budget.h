// SPDX-License-Identifier: Apache-2.0
// Memory-aware admission's arithmetic: a job's memory estimated from its declared point count
// before any point arrives, and the budget the running jobs' estimates must fit in.
//
// Measured (2026-11-25, Release, 2 arena threads, `scanprep simulate --scans 2` clouds: a box
// with a bore seen by two overlapping line scanners; one job per fresh server; peak VmHWM minus
// the idle server's VmRSS of 19.6 MiB, upload and download included;
// `PARAMS=... THREADS=2 deploy/run-e2e-benchmark.sh N`), in bytes per point, after the k-NN
// graph was made compact and the grid's sort keys narrow (before: 241 / 398 / 308 / 491 at 1 M,
// 283 / 305 at 4 M):
//   points      default   k = 64   correction.radius_scale = 100   both
//   1,000,000     191       304                280                   396
//   4,000,000     236                          280
//  20,000,000     297 (the job limit; 322 before; docs/benchmarks.md "Largest job")
// Correction caches each overlapping point's ball of radius r_c (r_c at most 2 r_g, so at most
// about 4k points), compactly and within a budget of kBallCacheBytesPerPoint per point
// (core/spatial/ball_cache.h), so the radius_scale = 100 rows, where every ball is at that
// limit, are the worst a job can reach; before the cache was bounded they were 554-569. The
// rest is the k-NN graph (2 B per neighbour as a rank difference, 4 B in a list that needs 32-bit
// indices), the grid, the cloud and the per-point measures; it grows by about 2.6 B per
// neighbour. The per-job overhead (thread-local buffers, one 4 MiB gRPC
// message) is bounded by kJobOverheadBytes. The upload holds the assembled arrays
// (xyz, scan, optional scanline, quality, intensity: 16-28 B/point, three times that for the
// moment a vector grows) and one chunk message (at most 4 MiB) at a time, far below the peak.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "absl/status/statusor.h"
#include "core/pipeline/params.h"

namespace scanprep::server {

// k = 20: the worst measured, 280 B/point (balls at their limit), with a 49 % margin. It was set
// at 35 % over the 308 measured before the k-NN graph was made compact, and is kept: a cloud
// whose k-NN lists all need 32-bit indices (Neighbourhoods::wide_lists; 5-6 % on the measured
// clouds) holds 136 B/point of graph instead of about 53 (and the old 80), 308 + 56 = 364.
inline constexpr uint64_t kBytesPerPoint = 416;
// Each neighbour above k = 20: measured 2.6 B, with a margin (k = 64 at the limit: 768 B
// estimated, 396 measured). A smaller k is estimated as k = 20.
inline constexpr uint64_t kBytesPerPointPerExtraNeighbour = 8;
inline constexpr int kDefaultNeighbours = 20;
inline constexpr uint64_t kJobOverheadBytes = uint64_t{16} << 20;
// The server's own memory outside any job: the idle process (19.6 MiB), gRPC's buffers of the
// queued calls' headers (4 MiB each at most) and the metrics endpoint.
inline constexpr uint64_t kServerReserveBytes = uint64_t{128} << 20;
// Without a container limit, the share of the machine's RAM the jobs may take.
inline constexpr double kShareOfRam = 0.5;

// "93 MiB", for messages.
std::string FormatMiB(double bytes);

// Bytes one job's points cost at the peak, for `params`' neighbourhoods.k (validated already).
uint64_t BytesPerPoint(const ParamOverrides& params);
// The memory a job of `points` points reserves while it holds a slot.
uint64_t EstimateJobBytes(uint64_t points, const ParamOverrides& params);

struct MemoryBudget {
  uint64_t bytes = 0;
  std::string source;  // how it was derived, for the startup log
};

// The automatic budget: the container's memory limit minus kServerReserveBytes, or without one
// (absent, "max", or not below MemTotal) kShareOfRam of `mem_total`. Fails when the limit leaves
// nothing after the reserve.
absl::StatusOr<MemoryBudget> AutoMemoryBudget(std::optional<uint64_t> container_limit,
                                              uint64_t mem_total);
// AutoMemoryBudget from cgroup v2 memory.max (or v1 memory.limit_in_bytes) and /proc/meminfo.
absl::StatusOr<MemoryBudget> DetectMemoryBudget();
// Contents of a cgroup limit file: a byte count, or nullopt for "max" / unreadable text.
std::optional<uint64_t> ParseCgroupLimit(std::string_view text);

// The largest job --max_points_per_job defaults to: also bounded by the memory budget.
inline constexpr uint64_t kDefaultMaxPointsPerJob = 20'000'000;

// Points of the largest job (default parameters) whose estimate fits in `budget_bytes`.
uint64_t LargestJobPoints(uint64_t budget_bytes);

struct MemoryLimits {
  MemoryBudget budget;
  uint64_t max_points_per_job = 0;
};

// The limits in force from the flags: the budget is `budget_flag` bytes, or when 0
// DetectMemoryBudget(); `max_points_flag` is the largest job, or when 0 kDefaultMaxPointsPerJob
// or LargestJobPoints, whichever is smaller. Fails when a job at an explicit `max_points_flag`
// (default parameters) could never fit the budget, a limit the server could not meet.
absl::StatusOr<MemoryLimits> ResolveMemoryLimits(uint64_t budget_flag, uint64_t max_points_flag);

}  // namespace scanprep::server
