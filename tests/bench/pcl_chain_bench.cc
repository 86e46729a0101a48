// SPDX-License-Identifier: Apache-2.0
// Issue 6's baseline: the cleaning chain a PCL 1.13 user would write — StatisticalOutlierRemoval,
// NormalEstimationOMP, MovingLeastSquares, VoxelGrid — over the same reference cloud as
// pipeline_bench, as a whole (BM_PclChain) and step by step. Arguments: {points, threads}; the
// thread count reaches the steps PCL parallelises (normals, MLS); SOR and VoxelGrid have no thread
// setting and run serially in both rows. Built only when libpcl-dev is installed; run through
// tools/run-benchmarks.sh, which adds these rows to the table of docs/benchmarks.md.
#include <chrono>
#include <cmath>
#include <map>
#include <memory>
#include <string>

#include <benchmark/benchmark.h>
#include <pcl/common/io.h>
#include <pcl/features/normal_3d_omp.h>
#include <pcl/filters/statistical_outlier_removal.h>
#include <pcl/filters/voxel_grid.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/search/kdtree.h>
#include <pcl/surface/mls.h>

#include "tests/bench/bench_cloud.h"
#include "tests/support/kdtree.h"

namespace scanprep::bench {
namespace {

using Xyz = pcl::PointCloud<pcl::PointXYZ>;
using Normals = pcl::PointCloud<pcl::Normal>;
using Oriented = pcl::PointCloud<pcl::PointNormal>;

// The settings.
constexpr int kSorMeanK = 20;
constexpr double kSorStddevMul = 2.0;
constexpr int kNormalK = 20;
constexpr float kVoxelLeafMm = 0.5f;
// MLS needs a search radius and PCL derives none. 3 x the mean nearest-neighbour spacing holds
// about the closest 20-30 points of a sampled surface (pi * 3^2 spacings^2), like the k = 20 of
// the other steps, and comfortably more than the 6 a second-order polynomial fit needs; on these
// laser-line scans (lines twice as far apart as points along a line) it still spans the
// neighbouring lines on both sides, so the fit is two-dimensional.
constexpr double kMlsRadiusPerSpacing = 3.0;

// The reference cloud as PCL points, converted once per size outside every timed loop.
Xyz::ConstPtr PclCloud(size_t points) {
  static std::map<size_t, Xyz::ConstPtr> cache;
  auto& slot = cache[points];
  if (!slot) {
    const PointCloud& cloud = ReferenceCloud(points);
    auto converted = std::make_shared<Xyz>();
    converted->reserve(cloud.size());
    for (size_t i = 0; i < cloud.size(); ++i) {
      converted->push_back(pcl::PointXYZ(cloud.x[i], cloud.y[i], cloud.z[i]));
    }
    slot = converted;
  }
  return slot;
}

double MlsRadiusMm(size_t points) {
  static std::map<size_t, double> cache;
  auto [slot, inserted] = cache.try_emplace(points, 0.0);
  if (inserted) {
    const PointCloud& cloud = ReferenceCloud(points);
    const KdTree tree(cloud);
    double sum = 0;
    for (size_t i = 0; i < cloud.size(); ++i) {
      const float q[3] = {cloud.x[i], cloud.y[i], cloud.z[i]};
      uint32_t index[2];
      float dist_sq[2];
      tree.Knn(q, 2, index, dist_sq);  // the point itself, then its nearest neighbour
      sum += std::sqrt(dist_sq[1]);
    }
    slot->second = kMlsRadiusPerSpacing * sum / static_cast<double>(cloud.size());
  }
  return slot->second;
}

Xyz::Ptr RemoveOutliers(const Xyz::ConstPtr& in) {
  pcl::StatisticalOutlierRemoval<pcl::PointXYZ> sor;
  sor.setInputCloud(in);
  sor.setMeanK(kSorMeanK);
  sor.setStddevMulThresh(kSorStddevMul);
  auto out = std::make_shared<Xyz>();
  sor.filter(*out);
  return out;
}

Normals::Ptr EstimateNormals(const Xyz::ConstPtr& in, int threads) {
  pcl::NormalEstimationOMP<pcl::PointXYZ, pcl::Normal> ne(threads);
  ne.setInputCloud(in);
  ne.setSearchMethod(std::make_shared<pcl::search::KdTree<pcl::PointXYZ>>());
  ne.setKSearch(kNormalK);
  auto out = std::make_shared<Normals>();
  ne.compute(*out);
  return out;
}

// Second-order MLS projection. Normals are not recomputed: for PointNormal input MLS copies the
// ones the chain estimated (fields it does not compute are carried over from the input point).
template <typename P>
typename pcl::PointCloud<P>::Ptr Smooth(const typename pcl::PointCloud<P>::ConstPtr& in,
                                        double radius, int threads) {
  pcl::MovingLeastSquares<P, P> mls;
  mls.setInputCloud(in);
  mls.setSearchMethod(std::make_shared<pcl::search::KdTree<P>>());
  mls.setPolynomialOrder(2);
  mls.setSearchRadius(radius);
  mls.setComputeNormals(false);
  mls.setNumberOfThreads(threads);
  auto out = std::make_shared<pcl::PointCloud<P>>();
  mls.process(*out);
  return out;
}

template <typename P>
typename pcl::PointCloud<P>::Ptr Simplify(const typename pcl::PointCloud<P>::ConstPtr& in) {
  pcl::VoxelGrid<P> voxel;
  voxel.setInputCloud(in);
  voxel.setLeafSize(kVoxelLeafMm, kVoxelLeafMm, kVoxelLeafMm);
  auto out = std::make_shared<pcl::PointCloud<P>>();
  voxel.filter(*out);
  return out;
}

int Threads(const benchmark::State& state) { return static_cast<int>(state.range(1)); }

void SetPclCounters(benchmark::State& state, size_t points_out) {
  SetCounters(state, PclCloud(state.range(0))->size());
  state.counters["points_out"] = static_cast<double>(points_out);
}

// Each step on the previous one's output; the per-step seconds come out as s_<step> counters,
// like the pipeline's per-stage breakdown.
void BM_PclChain(benchmark::State& state) {
  const Xyz::ConstPtr cloud = PclCloud(state.range(0));
  const double radius = MlsRadiusMm(state.range(0));
  std::map<std::string, double> step_seconds;
  auto timed = [&](const char* step, auto&& run) {
    const auto start = std::chrono::steady_clock::now();
    auto result = run();
    step_seconds[step] +=
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return result;
  };
  size_t points_out = 0;
  for (auto _ : state) {
    const Xyz::ConstPtr inliers = timed("s_sor", [&] { return RemoveOutliers(cloud); });
    const Normals::ConstPtr normals =
        timed("s_normals", [&] { return EstimateNormals(inliers, Threads(state)); });
    const Oriented::ConstPtr oriented = timed("s_concatenate", [&] {
      auto out = std::make_shared<Oriented>();
      pcl::concatenateFields(*inliers, *normals, *out);
      return out;
    });
    const Oriented::ConstPtr smoothed =
        timed("s_mls", [&] { return Smooth<pcl::PointNormal>(oriented, radius, Threads(state)); });
    const Oriented::ConstPtr simplified =
        timed("s_voxel", [&] { return Simplify<pcl::PointNormal>(smoothed); });
    points_out = simplified->size();
  }
  SetPclCounters(state, points_out);
  state.counters["mls_radius_mm"] = radius;
  for (const auto& [step, seconds] : step_seconds) {
    state.counters[step] = benchmark::Counter(seconds, benchmark::Counter::kAvgIterations);
  }
}

void BM_PclStatisticalOutlierRemoval(benchmark::State& state) {
  const Xyz::ConstPtr cloud = PclCloud(state.range(0));
  size_t points_out = 0;
  for (auto _ : state) points_out = RemoveOutliers(cloud)->size();
  SetPclCounters(state, points_out);
}

void BM_PclNormalEstimationOMP(benchmark::State& state) {
  const Xyz::ConstPtr cloud = PclCloud(state.range(0));
  size_t points_out = 0;
  for (auto _ : state) points_out = EstimateNormals(cloud, Threads(state))->size();
  SetPclCounters(state, points_out);
}

void BM_PclMovingLeastSquares(benchmark::State& state) {
  const Xyz::ConstPtr cloud = PclCloud(state.range(0));
  const double radius = MlsRadiusMm(state.range(0));
  size_t points_out = 0;
  for (auto _ : state) points_out = Smooth<pcl::PointXYZ>(cloud, radius, Threads(state))->size();
  SetPclCounters(state, points_out);
  state.counters["mls_radius_mm"] = radius;
}

void BM_PclVoxelGrid(benchmark::State& state) {
  const Xyz::ConstPtr cloud = PclCloud(state.range(0));
  size_t points_out = 0;
  for (auto _ : state) points_out = Simplify<pcl::PointXYZ>(cloud)->size();
  SetPclCounters(state, points_out);
}

// 4 M points stay in every case: MLS, the slowest step, took 6.1 s serially at 1 M points on the
// 2-core reference machine, so a 4 M iteration (~25 s) is long but bearable.
BENCHMARK(BM_PclChain)->Apply(Sizes)->UseRealTime();
BENCHMARK(BM_PclStatisticalOutlierRemoval)->Apply(Sizes)->UseRealTime();
BENCHMARK(BM_PclNormalEstimationOMP)->Apply(Sizes)->UseRealTime();
BENCHMARK(BM_PclMovingLeastSquares)->Apply(Sizes)->UseRealTime();
BENCHMARK(BM_PclVoxelGrid)->Apply(Sizes)->UseRealTime();

}  // namespace
}  // namespace scanprep::bench

BENCHMARK_MAIN();
