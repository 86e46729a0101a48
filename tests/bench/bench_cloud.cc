// SPDX-License-Identifier: Apache-2.0
#include "tests/bench/bench_cloud.h"

#include <algorithm>
#include <map>
#include <memory>

#include <sys/resource.h>

#include "absl/strings/str_cat.h"
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

void Sizes(benchmark::internal::Benchmark* b) {
  for (int64_t points : {100'000, 1'000'000, 4'000'000}) {
    for (int64_t threads : {1, 2}) b->Args({points, threads});
  }
  Timing(b);
}

void Timing(benchmark::internal::Benchmark* b) { b->Unit(benchmark::kMillisecond)->MinTime(0.5); }

}  // namespace scanprep::bench
