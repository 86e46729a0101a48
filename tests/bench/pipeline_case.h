// SPDX-License-Identifier: Apache-2.0
// The pipeline as a benchmark case, shared by the stage/pipeline cases and the hostile-input
// family.
#pragma once

#include <string>

#include <benchmark/benchmark.h>

#include "core/base/point_cloud.h"
#include "core/stages/params.h"
#include "tests/bench/bench_cloud.h"

namespace scanprep::bench {

// The pipeline over a fresh copy of the cloud each iteration, timed by its own report:
// `stage` empty = the whole default pipeline, else that stage alone (the prerequisites its plan
// runs first are timed by their own cases). `workload` makes the cloud of a point count;
// `params` overrides stage parameters. Arguments: {points, threads}. A refused or failed run is
// the case's error (its status message).
void RunPipelineCase(benchmark::State& state, const std::string& stage,
                     const PointCloud& (*workload)(size_t) = ReferenceCloud,
                     const ParamOverrides& params = {});

}  // namespace scanprep::bench
