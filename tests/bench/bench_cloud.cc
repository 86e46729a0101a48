#include "tests/bench/bench_cloud.h"

#include <map>
#include <memory>

#include <sys/resource.h>

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
  b->Unit(benchmark::kMillisecond)->MinTime(0.5);
}

}  // namespace scanprep::bench
