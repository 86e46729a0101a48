// SPDX-License-Identifier: Apache-2.0
// The hostile-input family (issue 11, docs/hostile-inputs.md): the whole default pipeline on the
// reference cloud with one thing wrong (tests/bench/hostile_cloud.h), and on the reference cloud
// with each numeric parameter of the registry set to each of -1, 0, 1e-30, 1e30, 2^32 and NaN.
// Cases BM_Hostile/<case>/<points>/<threads>; a refused parameter is the case's error, with the
// status message. Run through tools/run-benchmarks.sh 'Hostile' with CASE_TIMEOUT set, since a
// case of the unbounded code may not end; the same cases through the service are
// tools/run-hostile-benchmark.sh.
#include <string>
#include <utility>

#include <benchmark/benchmark.h>

#include "absl/strings/str_cat.h"
#include "core/pipeline/pipeline.h"
#include "tests/bench/bench_cloud.h"
#include "tests/bench/hostile_cloud.h"
#include "tests/bench/pipeline_case.h"

namespace scanprep::bench {
namespace {

// Big enough that a cost cliff shows, small enough that the ordinary cloud takes well under a
// second; the service script's default size.
constexpr int64_t kPoints = 100'000;
constexpr int64_t kThreads = 2;

void Register(const std::string& name, const PointCloud& (*workload)(size_t),
              ParamOverrides params = {}) {
  benchmark::RegisterBenchmark(
      absl::StrCat("BM_Hostile/", name).c_str(),
      [workload, params](benchmark::State& state) { RunPipelineCase(state, "", workload, params); })
      ->Args({kPoints, kThreads})
      ->Apply(Timing)
      ->UseManualTime();
}

bool RegisterHostileCases() {
  const std::pair<const char*, const PointCloud& (*)(size_t)> clouds[] = {
      {"ordinary", ReferenceCloud},
      {"far_point_1e6", FarPoint1e6Cloud},
      {"far_point_1e8", FarPoint1e8Cloud},
      {"coincident_10pct", Coincident10PctCloud},
      {"coincident_50pct", Coincident50PctCloud},
      {"dense_spot_25pct", DenseSpot25PctCloud},
      {"dense_spot_50pct", DenseSpot50PctCloud},
      {"line", LineCloud},
      {"plane", PlaneCloud},
      {"metre_data_as_mm", MetreDataAsMmCloud},
      {"mm_data_as_metres", MmDataAsMetresCloud},
      {"no_pose_unorganized", NoPoseUnorganizedCloud},
      {"one_point_scans_1000", OnePointScans1000Cloud},
      {"ordinary_in_1000_scans", OrdinaryIn1000ScansCloud},
  };
  for (const auto& [name, workload] : clouds) Register(name, workload);
  for (const ParamSpec& spec : AllParamSpecs()) {
    if (!spec.choices.empty()) continue;  // numeric parameters only
    for (const char* value : {"-1", "0", "1e-30", "1e30", "4294967296", "nan"}) {
      Register(absl::StrCat(spec.name, "=", value), ReferenceCloud, {{spec.name, value}});
    }
  }
  return true;
}

const bool kRegistered = RegisterHostileCases();

}  // namespace
}  // namespace scanprep::bench
