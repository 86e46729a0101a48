// SPDX-License-Identifier: Apache-2.0
// Google Benchmark cases for issue 6: each stage, the neighbour graph, the whole default pipeline,
// and the baseline every target is a ratio to: a bare nanoflann build + k=20 kNN loop (TBB) over
// the same points. Arguments: {points, threads}. Run through tools/run-benchmarks.sh, which
// prints the docs/benchmarks.md table.
#include <string>
#include <vector>

#include <benchmark/benchmark.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "core/pipeline/presets.h"
#include "core/spatial/neighbourhoods.h"
#include "tests/bench/bench_cloud.h"
#include "tests/bench/pipeline_case.h"
#include "tests/support/kdtree.h"

namespace scanprep::bench {
namespace {

constexpr size_t kK = 20;

// The peer to beat: nanoflann's own tree over the same arrays and one k=20 query per point.
void BM_BareNanoflannKnn(benchmark::State& state) {
  const PointCloud& cloud = ReferenceCloud(state.range(0));
  tbb::task_arena arena(static_cast<int>(state.range(1)));
  std::vector<uint32_t> index(cloud.size() * kK);
  std::vector<float> dist(cloud.size() * kK);
  for (auto _ : state) {
    arena.execute([&] {
      KdTree tree(cloud);
      tbb::parallel_for(tbb::blocked_range<size_t>(0, cloud.size(), 1024),
                        [&](const tbb::blocked_range<size_t>& r) {
                          for (size_t i = r.begin(); i < r.end(); ++i) {
                            const float q[3] = {cloud.x[i], cloud.y[i], cloud.z[i]};
                            tree.Knn(q, kK, &index[i * kK], &dist[i * kK]);
                          }
                        });
    });
    benchmark::DoNotOptimize(index.data());
  }
  SetCounters(state, cloud.size());
}

void BM_NeighbourGraph(benchmark::State& state) {
  const PointCloud& cloud = ReferenceCloud(state.range(0));
  tbb::task_arena arena(static_cast<int>(state.range(1)));
  CancelToken cancel;
  for (auto _ : state) {
    arena.execute([&] {
      auto nb = Neighbourhoods::Build(cloud, {.k = kK}, cancel);
      benchmark::DoNotOptimize(nb);
    });
  }
  SetCounters(state, cloud.size());
}

BENCHMARK(BM_BareNanoflannKnn)->Apply(Sizes)->UseRealTime();
BENCHMARK(BM_NeighbourGraph)->Apply(Sizes)->UseRealTime();
BENCHMARK_CAPTURE(RunPipelineCase, DefaultPipeline, std::string())->Apply(Sizes)->UseManualTime();
// The preset `paper`; `metrology` is DefaultPipeline (its parameters are the defaults).
BENCHMARK_CAPTURE(RunPipelineCase, PaperPreset, std::string(), ReferenceCloud,
                  *ResolvePreset(BuiltinPresets(), "paper", {}))
    ->Apply(Sizes)
    ->UseManualTime();
// 4 M points at the 1 M density: whether the pipeline scales with the point count alone.
BENCHMARK_CAPTURE(RunPipelineCase, DefaultPipelinePartsInARow, std::string(), PartsInARowCloud)
    ->Apply(PartsInARowSizes)
    ->UseManualTime();
// The same points without scanlines (a point soup from a flexible scanner).
BENCHMARK_CAPTURE(RunPipelineCase, DefaultPipelineUnorganized, std::string(), UnorganizedCloud)
    ->Args({1'000'000, 2})
    ->Apply(Timing)
    ->UseManualTime();
BENCHMARK_CAPTURE(RunPipelineCase, outliers, std::string("outliers"))
    ->Apply(Sizes)
    ->UseManualTime();
BENCHMARK_CAPTURE(RunPipelineCase, normals, std::string("normals"))->Apply(Sizes)->UseManualTime();
BENCHMARK_CAPTURE(RunPipelineCase, measures, std::string("measures"))
    ->Apply(Sizes)
    ->UseManualTime();
BENCHMARK_CAPTURE(RunPipelineCase, registration, std::string("registration"))
    ->Apply(Sizes)
    ->UseManualTime();
BENCHMARK_CAPTURE(RunPipelineCase, correction, std::string("correction"))
    ->Apply(Sizes)
    ->UseManualTime();
BENCHMARK_CAPTURE(RunPipelineCase, smoothing, std::string("smoothing"))
    ->Apply(Sizes)
    ->UseManualTime();
BENCHMARK_CAPTURE(RunPipelineCase, simplification, std::string("simplification"))
    ->Apply(Sizes)
    ->UseManualTime();
// The nearest equivalent of a 0.5 mm voxel grid (CGAL grid_simplify, PCL VoxelGrid): uniform
// thinning to r_s = 0.5 mm.
BENCHMARK_CAPTURE(RunPipelineCase, uniform_simplification_0_5mm, std::string("simplification"),
                  ReferenceCloud,
                  ParamOverrides{{"simplification.mode", "uniform"},
                                 {"simplification.spacing_mm", "0.5"}})
    ->Apply(Sizes)
    ->UseManualTime();

}  // namespace
}  // namespace scanprep::bench

int main(int argc, char** argv) {
  // TBB keeps one slot for a master thread by default; the arenas here need every thread.
  tbb::global_control workers(tbb::global_control::max_allowed_parallelism, 64);
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
