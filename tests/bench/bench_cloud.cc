// SPDX-License-Identifier: Apache-2.0
#include "tests/bench/bench_cloud.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>
#include <string>

#include <sys/resource.h>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "absl/strings/string_view.h"
#include "core/sim/scan_simulator.h"

namespace scanprep::bench {

const PointCloud& ReferenceCloud(size_t points) {
  static std::map<size_t, std::unique_ptr<PointCloud>> cache;
  auto& slot = cache[points];
  if (!slot) {
    const auto part = sim::Part::kBoxWithBore;
    slot = std::make_unique<PointCloud>(
        sim::SimulateWithPointCount(part, sim::TwoOverlappingSensors(part), points, 0.01, 1).cloud);
  }
  return *slot;
}

const PointCloud& PartsInARowCloud(size_t points) {
  static std::map<size_t, std::unique_ptr<PointCloud>> cache;
  auto& slot = cache[points];
  if (!slot) {
    const PointCloud& part = ReferenceCloud(1'000'000);
    const auto [lo, hi] = std::minmax_element(part.x.begin(), part.x.end());
    const float step = 1.5f * (*hi - *lo);  // half a part's length between parts
    const size_t copies = std::max<size_t>(1, (points + 999'999) / 1'000'000);
    auto row = std::make_unique<PointCloud>();
    row->kind = part.kind;
    const auto append = [](std::vector<float>& to, const std::vector<float>& from, float shift) {
      for (const float v : from) to.push_back(v + shift);
    };
    for (size_t c = 0; c < copies; ++c) {
      const float shift = static_cast<float>(c) * step;
      const auto first_scan = static_cast<uint32_t>(row->scans.size());
      for (ScanMeta scan : part.scans) {
        scan.id = absl::StrCat(scan.id, "#", c);
        for (auto* position : {&scan.camera_position, &scan.projector_position}) {
          if (position->has_value()) (*position)->x() += shift;
        }
        row->scans.push_back(std::move(scan));
      }
      append(row->x, part.x, shift);
      append(row->y, part.y, 0);
      append(row->z, part.z, 0);
      append(row->quality, part.quality, 0);
      append(row->intensity, part.intensity, 0);
      for (const uint32_t s : part.scan) row->scan.push_back(first_scan + s);
      row->scanline.insert(row->scanline.end(), part.scanline.begin(), part.scanline.end());
    }
    row->FinishLoading();
    slot = std::move(row);
  }
  return *slot;
}

const PointCloud& UnorganizedCloud(size_t points) {
  static std::map<size_t, std::unique_ptr<PointCloud>> cache;
  auto& slot = cache[points];
  if (!slot) {
    slot = std::make_unique<PointCloud>(ReferenceCloud(points));
    slot->scanline.clear();
    slot->kind = ScannerKind::kFlexible;
    for (ScanMeta& scan : slot->scans) scan.scanline_spacing = 0;
  }
  return *slot;
}

double PeakRssBytes() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_maxrss * 1024.0;
}

void SetCounters(benchmark::State& state, size_t points) {
  state.counters["points"] = static_cast<double>(points);
  state.counters["threads"] = static_cast<double>(state.range(1));
  state.counters["points_per_second"] = benchmark::Counter(
      static_cast<double>(points), benchmark::Counter::kIsIterationInvariantRate);
  state.counters["peak_rss_bytes"] = PeakRssBytes();
}

std::vector<int64_t> BenchThreads(std::vector<int64_t> fallback) {
  const char* list = std::getenv("SCANPREP_BENCH_THREADS");
  if (list == nullptr || *list == '\0') return fallback;
  std::vector<int64_t> threads;
  for (absl::string_view item : absl::StrSplit(list, ',')) {
    int64_t count = 0;
    if (!absl::SimpleAtoi(item, &count) || count < 1 || count > 1024) {
      std::fprintf(stderr, "SCANPREP_BENCH_THREADS: '%s' is not a thread count from 1 to 1024\n",
                   std::string(item).c_str());
      std::exit(2);
    }
    threads.push_back(count);
  }
  return threads;
}

void Sizes(benchmark::internal::Benchmark* b) {
  const std::vector<int64_t> threads = BenchThreads({1, 2});
  for (int64_t points : {100'000, 1'000'000, 4'000'000}) {
    for (int64_t t : threads) b->Args({points, t});
  }
  Timing(b);
}

void PartsInARowSizes(benchmark::internal::Benchmark* b) {
  for (int64_t t : BenchThreads({2})) b->Args({4'000'000, t});
  Timing(b);
}

void Timing(benchmark::internal::Benchmark* b) { b->Unit(benchmark::kMillisecond)->MinTime(0.5); }

}  // namespace scanprep::bench
