// SPDX-License-Identifier: Apache-2.0
#include "tests/support/metrology_job.h"

#include <chrono>

namespace scanprep::testing {

sim::SimulatedCloud SimulateScan(sim::Part part, double sigma, size_t points, uint64_t seed) {
  std::vector<sim::SimSensor> sensors = sim::ThreeOverlappingSensors(part);
  for (sim::SimSensor& s : sensors) s.noise_sigma = sigma;
  return sim::SimulateWithPointCount(part, std::move(sensors), points, kEvaluationSpikeShare, seed);
}

sim::SimulatedCloud SimulateEvaluationScan(size_t points, uint64_t seed) {
  return SimulateScan(kEvaluationPart, kEvaluationSigmaMm, points, seed);
}

PointCloud WithUserMetadata(const sim::SimulatedCloud& sim, double sigma) {
  PointCloud cloud = sim.cloud;
  for (ScanMeta& scan : cloud.scans) scan.uncertainty = sigma;
  return cloud;
}

PointCloud WithoutMetadata(const sim::SimulatedCloud& sim) {
  PointCloud cloud;
  cloud.x = sim.cloud.x;
  cloud.y = sim.cloud.y;
  cloud.z = sim.cloud.z;
  cloud.kind = ScannerKind::kFlexible;
  ScanMeta only;
  only.id = "all";
  cloud.scans = {only};
  cloud.FinishLoading();
  return cloud;
}

absl::StatusOr<StagesRun> RunStages(PointCloud cloud, const std::vector<std::string>& stages,
                                    const ParamOverrides& params) {
  PipelineOptions options;
  options.stages = stages;
  options.params = params;
  const CancelToken never;
  const auto start = std::chrono::steady_clock::now();
  auto report = RunPipeline(cloud, options, never);
  if (!report.ok()) return report.status();
  const std::chrono::duration<double> took = std::chrono::steady_clock::now() - start;
  return StagesRun{std::move(cloud), std::move(*report), took.count()};
}

}  // namespace scanprep::testing
