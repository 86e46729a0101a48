// SPDX-License-Identifier: Apache-2.0
// Memory-aware admission's arithmetic: a job's memory reservation, estimated from its declared
// point count before any point arrives, and the server's memory capacity, which the running jobs'
// reservations must fit in together.
//
// Measured (2026-11-25, Release, 2 arena threads, `scanprep simulate --scans 2` clouds: a box
// with a bore seen by two overlapping line scanners; one job per fresh server; peak VmHWM minus
// the idle server's VmRSS of 19.6 MiB, upload and download included;
// `PARAMS=... THREADS=2 tools/run-e2e-benchmark.sh N`), in bytes per point, after correction's
// ball cache was dropped, the grid and graph came to hold the point order once and the server's
// freed arrays went back to the system (docs/benchmarks.md "Server memory per point"; before,
// after the compact k-NN graph: 191 / 304 / 280 / 396 at 1 M, 236 / 280 at 4 M, 297 at 20 M):
//   points      default   k = 64   correction.radius_scale = 100   both
//   1,000,000   139-147     244                140                   245
//   4,000,000   136-139                        137
//  20,000,000     see docs/benchmarks.md "Largest job" (the job limit)
// Correction keeps no balls: r_c is at most 2 r_g, so the radius_scale = 100 rows, where every
// ball is at that limit, cost no more memory than the default. What a job holds is the k-NN
// graph (2 B per neighbour as a rank difference, 4 B in a list that needs 32-bit indices), the
// grid, the cloud and the per-point measures, and at its peak one stage's own arrays (the
// simplification's visiting order, smoothing's new positions); it grows by about 2.4 B per
// neighbour. The per-job overhead (thread-local buffers, one 4 MiB gRPC
// message) is bounded by kJobOverheadBytes. The upload holds the assembled arrays
// (xyz, scan, optional scanline, quality, intensity: 16-28 B/point, three times that for the
// moment a vector grows) and one chunk message (at most 4 MiB) at a time, far below the peak.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "absl/status/statusor.h"
#include "core/spatial/neighbourhoods.h"
#include "core/stages/params.h"

namespace scanprep::server {

// k = 20: set at 35 % over the 308 B/point measured before the k-NN graph was made compact, and
// kept while the jobs' memory came down (the worst measured now 147, with every correction ball
// at its limit 140): a cloud whose k-NN lists all need 32-bit indices (Neighbourhoods::
// wide_lists; 5-6 % on the measured clouds) holds about 84 B/point more graph, and the hostile
// inputs reach 1.53x the ordinary cloud's memory (docs/hostile-inputs.md). Lowering it would let
// more jobs run at once; that wants its own measurement of those worst cases first.
inline constexpr uint64_t kBytesPerPoint = 416;
// Each neighbour above k = 20: measured 2.4 B, with a margin (k = 64 at the limit: 768 B
// estimated, 245 measured). A smaller k is estimated as k = 20.
inline constexpr uint64_t kBytesPerPointPerExtraNeighbour = 8;
// The default neighbourhoods.k, at which kBytesPerPoint was measured.
inline constexpr int kDefaultNeighbours = static_cast<int>(kDefaultNeighbourK);
inline constexpr uint64_t kJobOverheadBytes = uint64_t{16} << 20;
// The server's own memory outside any job: the idle process (19.6 MiB), gRPC's buffers of the
// queued calls' headers (4 MiB each at most) and the metrics endpoint.
inline constexpr uint64_t kServerOwnBytes = uint64_t{128} << 20;
// Without a container limit, the share of the machine's RAM the jobs may take.
inline constexpr double kShareOfRam = 0.5;

// The memory guard (memory_guard.h) holds every job to its estimate whatever the input: no job
// takes more than its reservation plus this margin. Measured as the server's resident memory
// (/proc/self/statm, what the container's limit and VmHWM count) above its idle baseline (the
// resident memory at startup, then whenever no call holds a reservation), sampled every
// kMemoryGuardPeriodMs against the sum of the reservations of the admitted calls (uploads their
// data, jobs with a slot their estimate). The guard ends a job once that sum is crossed by a
// quarter of the margin (kMemoryGuardTripBytes); the other three quarters, 48 MiB, cover what the
// job's stage still allocates after the crossing: in the sampling period, and until it next looks
// at its cancel token (within 0.2 s, but an array a stage allocates in one step lands whole).
// Measured in subprocess_test (MemoryGuardHoldsAJobToItsReservation, a 1 M-point job reserving 17.8
// MB that needs about 150): the server peaked 45-49 MB above idle, 28-31 MB over the reservation,
// six runs on two cores shared with compilers, 2026-11-26 (at a trip of half the margin, the
// largest step after the crossing was 33 MiB); without the guard 149-156 MB. With the 128 MiB
// kServerOwnBytes over the capacity, the margin and the idle server (20 MiB) fit under the
// container's limit.
inline constexpr uint64_t kMemoryGuardMarginBytes = uint64_t{64} << 20;
inline constexpr uint64_t kMemoryGuardTripBytes = kMemoryGuardMarginBytes / 4;
inline constexpr int kMemoryGuardPeriodMs = 10;

// "93 MiB", for messages.
std::string FormatMiB(double bytes);

// TEST HOOK (scanprep-server --test_bytes_per_point): replaces kBytesPerPoint in every estimate
// this process makes from now on, so a test can send an ordinary job that genuinely takes more
// than its reservation, whatever input classes the estimate covers by then. 0 = kBytesPerPoint.
void SetBytesPerPointForTesting(uint64_t bytes);
// kBytesPerPoint, or the test hook's value.
uint64_t BaseBytesPerPoint();

// Bytes one job's points cost at the peak, for `params`' neighbourhoods.k (validated already).
uint64_t BytesPerPoint(const ParamOverrides& params);
// The memory a job of `points` points reserves while it holds a slot.
uint64_t EstimateJobBytes(uint64_t points, const ParamOverrides& params);

// What the admitted jobs may reserve together.
struct MemoryCapacity {
  uint64_t bytes = 0;
  std::string source;  // how it was derived, for the startup log
};

// The automatic capacity: the container's memory limit minus kServerOwnBytes, or without one
// (absent, "max", or not below MemTotal) kShareOfRam of `mem_total`. Fails when the limit leaves
// nothing after the reserve.
absl::StatusOr<MemoryCapacity> AutoMemoryCapacity(std::optional<uint64_t> container_limit,
                                                  uint64_t mem_total);
// AutoMemoryCapacity from cgroup v2 memory.max (or v1 memory.limit_in_bytes) and /proc/meminfo.
absl::StatusOr<MemoryCapacity> DetectMemoryCapacity();
// Contents of a cgroup limit file: a byte count, or nullopt for "max" / unreadable text.
std::optional<uint64_t> ParseCgroupLimit(std::string_view text);

// The largest job --max_points_per_job defaults to: also bounded by the memory capacity.
inline constexpr uint64_t kDefaultMaxPointsPerJob = 20'000'000;
// The largest --max_points_per_job at all: a job's points and their upload positions
// (PointChunk.source_index) are 32-bit indices.
inline constexpr uint64_t kMaxIndexablePoints = 0xFFFF'FFFFu;

// Points of the largest job (default parameters) whose estimate fits in `capacity_bytes`.
uint64_t LargestJobPoints(uint64_t capacity_bytes);

struct MemoryLimits {
  MemoryCapacity capacity;
  uint64_t max_points_per_job = 0;
};

// The limits in force from the flags: the capacity is `capacity_flag` bytes, or when 0
// DetectMemoryCapacity(); `max_points_flag` is the largest job, or when 0 kDefaultMaxPointsPerJob
// or LargestJobPoints, whichever is smaller. Fails when a job at an explicit `max_points_flag`
// (default parameters) could never fit the capacity, or its points could not be indexed
// (kMaxIndexablePoints): a limit the server could not meet.
absl::StatusOr<MemoryLimits> ResolveMemoryLimits(uint64_t capacity_flag, uint64_t max_points_flag);

}  // namespace scanprep::server
