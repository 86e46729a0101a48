// SPDX-License-Identifier: Apache-2.0
// The evaluation's fixture and jobs: the simulated three-scan stepped block, handed to the
// pipeline the way a user's files would reach it — with the metadata a user knows, or with none
// (one bare .xyz) — and run for a list of stages.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "core/base/point_cloud.h"
#include "core/pipeline/pipeline.h"
#include "core/sim/scan_simulator.h"

namespace scanprep::testing {

inline constexpr sim::Part kEvaluationPart = sim::Part::kSteppedBlock;
inline constexpr double kEvaluationSigmaMm = 0.01;     // every sensor's range noise
inline constexpr double kEvaluationSpikeShare = 0.01;  // injected spikes per scan

// The stepped block seen by ThreeOverlappingSensors, about `points` points, 1 % spikes.
sim::SimulatedCloud SimulateEvaluationScan(size_t points, uint64_t seed);

// `part` seen by ThreeOverlappingSensors with range noise `sigma`, about `points` points, 1 %
// spikes.
sim::SimulatedCloud SimulateScan(sim::Part part, double sigma, size_t points, uint64_t seed);

// One file per scan with its scanlines, as a user describes a laser-line scanner: camera
// position, projector direction, scanline and point spacing, and u = `sigma` — the sensor's
// stated uncertainty, not the simulator's conservative 3σ.
PointCloud WithUserMetadata(const sim::SimulatedCloud& sim, double sigma = kEvaluationSigmaMm);

// What the service makes of the same points sent as one bare .xyz file (`scanprep process
// all.xyz`: io::ReadXyz, client::BuildJob, server ScanMetaFromProto / KindFromHeader): one scan
// named after the file with the default uncertainty and nothing else, no scanlines, scanner
// kind FLEXIBLE (no scanline spacing was given).
PointCloud WithoutMetadata(const sim::SimulatedCloud& sim);

struct StagesRun {
  PointCloud cloud;  // the input, processed: removed points flagged, not dropped
  PipelineReport report;
  double seconds = 0;
};

// Runs `stages` (empty = the default pipeline) with default parameters, or `params` over them.
absl::StatusOr<StagesRun> RunStages(PointCloud cloud, const std::vector<std::string>& stages,
                                    const ParamOverrides& params = {});

}  // namespace scanprep::testing
