// SPDX-License-Identifier: Apache-2.0
// Memory peaks that a job's admission estimate and the per-point memory table rely on, measured
// with a counting allocator (this binary replaces operator new and delete): a freed array that
// is in fact still held shows up here as a higher peak, not as a wrong result.
#include <malloc.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <new>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "core/base/parallel.h"
#include "core/pipeline/pipeline.h"
#include "core/spatial/cell_grid.h"
#include "tests/support/hostile_mix.h"
#include "tests/support/random_clouds.h"

namespace {

std::atomic<long> live_bytes{0}, peak_bytes{0};

void* Allocate(size_t size) {
  void* p = std::malloc(size == 0 ? 1 : size);
  if (p == nullptr) throw std::bad_alloc();
  const long now = live_bytes += static_cast<long>(malloc_usable_size(p));
  long peak = peak_bytes.load();
  while (now > peak && !peak_bytes.compare_exchange_weak(peak, now)) {
  }
  return p;
}

void Release(void* p) {
  if (p == nullptr) return;
  live_bytes -= static_cast<long>(malloc_usable_size(p));
  std::free(p);
}

}  // namespace

void* operator new(size_t size) { return Allocate(size); }
void* operator new[](size_t size) { return Allocate(size); }
void operator delete(void* p) noexcept { Release(p); }
void operator delete[](void* p) noexcept { Release(p); }
void operator delete(void* p, size_t) noexcept { Release(p); }
void operator delete[](void* p, size_t) noexcept { Release(p); }

namespace scanprep {
namespace {

// A rebuild (smoothing's, after the points moved) frees the old entries before it sorts and the
// sort's keys before it fills the new entries, so it never holds two copies of the points: its
// peak stays at what the grid holds anyway. Holding the old entries would add 12 bytes a point,
// holding the keys 8.
TEST(MemoryPeak, GridRebuildHoldsOneCopyOfThePoints) {
  constexpr size_t kPoints = 300'000;
  const PointCloud cloud =
      testing::UniformBoxCloud(kPoints, {0.f, 0.f, -0.05f}, {60.f, 60.f, 0.05f}, 5);
  CancelToken cancel;
  CellGrid grid;
  ASSERT_TRUE(grid.Build(cloud, 0, cancel).ok());
  const long held = live_bytes.load();
  peak_bytes = held;
  ASSERT_TRUE(grid.Build(cloud, grid.cell_edge(), cancel).ok());
  const long extra = peak_bytes.load() - held;
  EXPECT_LE(extra, static_cast<long>(2 * kPoints)) << "bytes beyond the grid's own at the peak";
  // The rebuilt grid holds what the first build did (its cell tables within a byte a point).
  EXPECT_NEAR(double(live_bytes.load()), double(held), double(kPoints));
  // Control: the counter sees the grid's arrays (coordinates and order, 16 bytes a point).
  CellGrid fresh;
  const long before = live_bytes.load();
  ASSERT_TRUE(fresh.Build(cloud, grid.cell_edge(), cancel).ok());
  EXPECT_GE(live_bytes.load() - before, static_cast<long>(16 * kPoints));
}

// A sort (simplification's visiting order, correction's keys, the orientation's edges) needs
// half its items' size on top of them: each merge moves the shorter of its runs aside. A second
// copy of the items, as a merge into a separate array needs, would be twice that.
TEST(MemoryPeak, SortMovesHalfItsItemsAside) {
  constexpr size_t kItems = 1'000'000;
  std::vector<uint64_t> items(kItems);
  std::mt19937_64 rng(3);
  for (uint64_t& item : items) item = rng();
  CancelToken cancel;
  const long held = live_bytes.load();
  peak_bytes = held;
  ASSERT_TRUE(CancellableSort(items, cancel).ok());
  const long extra = peak_bytes.load() - held;
  EXPECT_LE(extra, static_cast<long>(kItems / 2 * sizeof(uint64_t) + (64 << 10)))
      << "bytes beyond the items at the peak";
  // Control: the counter sees the room set aside (more than one block needs merging).
  EXPECT_GE(extra, static_cast<long>(kItems / 2 * sizeof(uint64_t)));
  EXPECT_TRUE(std::is_sorted(items.begin(), items.end()));
}

// The whole pipeline's heap above what it started with, on a cloud the caller owns.
long PipelinePeak(PointCloud cloud, ParamOverrides params = {}) {
  const long held = live_bytes.load();
  peak_bytes = held;
  auto report = RunPipeline(cloud, {.params = std::move(params)}, CancelToken());
  EXPECT_TRUE(report.ok()) << report.status();
  return peak_bytes.load() - held;
}

// No input shape may push a job's memory past a bound per point: drawn hostile clouds (far parts,
// clusters of near-identical points, lines; tests/support/hostile_mix.h) peak within 2.5 times
// the ordinary sheet's heap of the same size (measured up to 2.04x: a far part of 29 % beside a
// cluster and a line, 50 k points; the service's peak memory, upload and all, stays within 1.33x
// on the hostile benchmark). Simplification gathered a batch of balls ahead, sized for balls of
// the global density: in a cluster each held thousands of points (450 MB at 100 k points, 26x
// the ordinary job) until a ball that full was queried again at its turn instead.
TEST(MemoryPeak, HostileCloudsPeakWithinTwoAndAHalfTimesTheOrdinary) {
  constexpr size_t kPoints = 50'000;
  const long ordinary = PipelinePeak(testing::DrawHostileMix(kPoints, 1, {.none = true}).cloud);
  // The controls, every run: two fixed draws. Seed 2, three clusters of 10 k points and nothing
  // else, spread 5 µm wide, fifty times the cubes the duplicates pass joins (u/100), so their
  // points stay apart (their balls are their k-NN lists, a dense spot's stand-in): within 1.6x
  // (1.19x). Seed 1203272827, a far part of 11.7 %, two clusters and a line, whose simplification
  // balls are full (14 k capped, 28 k points left out): within 2.5x (1.1x; 5.9x with full balls
  // kept in the batch). The other draws afresh, any mix, within 2.5x.
  const uint64_t seed = std::random_device()();
  for (uint64_t draw = 0; draw < 4; ++draw) {
    const bool control = draw == 0;
    const uint64_t drawn = control ? 2 : draw == 1 ? 1203272827 : seed + draw;
    const testing::HostileMix mix = testing::DrawHostileMix(
        kPoints, drawn, {.clusters = control, .cluster_spread = control ? 5e-3 : 0});
    SCOPED_TRACE(mix.description + "seed " + std::to_string(drawn));
    const long peak = PipelinePeak(mix.cloud);
    std::printf("%.2fx the ordinary peak: %s\n", double(peak) / ordinary, mix.description.c_str());
    EXPECT_LE(peak, control ? 8 * ordinary / 5 : 5 * ordinary / 2) << "ordinary " << ordinary;
    if (!control) continue;
    // The other visiting order, the tiled one, within the same bound.
    const long tiled = PipelinePeak(mix.cloud, {{"simplification.order", "tiled"}});
    std::printf("%.2fx the ordinary peak, tiled simplification\n", double(tiled) / ordinary);
    EXPECT_LE(tiled, 8 * ordinary / 5) << "tiled; ordinary " << ordinary;
  }
}

}  // namespace
}  // namespace scanprep
