// SPDX-License-Identifier: Apache-2.0
// The benchmark workload: a generated two-scan laser-line cloud of a box with a bore, with noise
// and 1 % spikes (the reference cloud), cached per size so every case times the same
// points.
#pragma once

#include <cstddef>

#include <vector>

#include <benchmark/benchmark.h>

#include "core/base/point_cloud.h"

namespace scanprep::bench {

const PointCloud& ReferenceCloud(size_t points);

// About `points` points at the 1 M cloud's density: ⌈points / 1 M⌉ copies of the 1 M cloud side
// by side along x, each with its own two scans, like parts in a row on one conveyor. The 4 M
// ReferenceCloud is the same part sampled denser, which makes every ball fuller; this one scales
// the point count alone.
const PointCloud& PartsInARowCloud(size_t points);

// ReferenceCloud(points) as a point soup: no scanlines, a flexible scanner without a scanline
// spacing (r_min = ε_u), the poses kept. Issue 14's unorganized case.
const PointCloud& UnorganizedCloud(size_t points);

// Peak resident set size of this process so far, in bytes.
double PeakRssBytes();

// The counters tools/run-benchmarks.sh turns into the table: points, threads (the case's second
// argument), points_per_second, peak_rss_bytes.
void SetCounters(benchmark::State& state, size_t points);

// The thread counts a run measures: SCANPREP_BENCH_THREADS, a comma-separated list (e.g.
// "1,2,4,8,16" on a many-core machine, tools/run-scaling-benchmark.sh), else `fallback`. A value
// that is not a count from 1 to 1024 stops the run with a message naming it.
std::vector<int64_t> BenchThreads(std::vector<int64_t> fallback);

// Every case's arguments {points, threads}: 100 k, 1 M and 4 M points on 1 and 2 threads
// (BenchThreads); the minimum time is short enough that one iteration suffices at the large sizes.
void Sizes(benchmark::internal::Benchmark* b);

// {4 M, threads} for the 4 M-points-at-the-1 M-density case: 2 threads (BenchThreads).
void PartsInARowSizes(benchmark::internal::Benchmark* b);

// Milliseconds, and a minimum time short enough that one iteration suffices at the large sizes;
// part of Sizes, and for cases with arguments of their own.
void Timing(benchmark::internal::Benchmark* b);

}  // namespace scanprep::bench
