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

}  // namespace scanprep::bench
