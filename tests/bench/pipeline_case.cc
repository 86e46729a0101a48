// SPDX-License-Identifier: Apache-2.0
#include "tests/bench/pipeline_case.h"

#include <map>

#include <tbb/task_arena.h>

#include "core/base/cancel.h"
#include "core/pipeline/pipeline.h"

namespace scanprep::bench {

void RunPipelineCase(benchmark::State& state, const std::string& stage,
                     const PointCloud& (*workload)(size_t), const ParamOverrides& params) {
  const PointCloud& reference = workload(state.range(0));
  tbb::task_arena arena(static_cast<int>(state.range(1)));
  CancelToken cancel;
  PipelineOptions options;
  options.params = params;
  if (!stage.empty()) options.stages = {stage};
  std::map<std::string, double> stage_seconds;  // per-stage breakdown of the whole pipeline
  for (auto _ : state) {
    PointCloud cloud = reference;
    absl::StatusOr<PipelineReport> report;
    arena.execute([&] { report = RunPipeline(cloud, options, cancel); });
    if (!report.ok()) {
      state.SkipWithError(std::string(report.status().message()).c_str());
      return;
    }
    double seconds = stage.empty() ? report->total_seconds : 0;
    for (const StageReport& s : report->stages) {
      seconds += s.name == stage ? s.seconds : 0;
      stage_seconds[s.name] += s.seconds;
    }
    state.SetIterationTime(seconds);
  }
  SetCounters(state, reference.size());
  if (stage.empty()) {
    for (const auto& [name, seconds] : stage_seconds) {
      state.counters["s_" + name] = benchmark::Counter(seconds, benchmark::Counter::kAvgIterations);
    }
  }
}

}  // namespace scanprep::bench
