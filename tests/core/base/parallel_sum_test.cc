// SPDX-License-Identifier: Apache-2.0
// ParallelSum adds its blocks in block order, so a floating-point sum is the same on any number
// of threads (health's pair estimate relies on it); ValuesPerScan hands every value to its scan
// exactly once, whatever the threads; both stop with CANCELLED when asked.
#include <algorithm>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include "core/base/parallel.h"
#include "core/base/per_scan_values.h"

namespace scanprep {
namespace {

constexpr size_t kGrain = 4096;

// Values whose double sum depends on the order its blocks are added in: the first block holds
// 1e17 (an ulp of 16), every other block sums to exactly 3. Added in block order each 3 is lost
// to rounding; the 3s added first survive as 75 before 1e17 comes in.
std::vector<double> OrderSensitive(size_t n) {
  std::vector<double> v(n, 3.0 / kGrain);
  v[0] = 1e17;
  return v;
}

double SumOn(int threads, const std::vector<double>& v) {
  double sum = 0;
  CancelToken cancel;
  tbb::task_arena(threads).execute([&] {
    EXPECT_TRUE(ParallelSum(
                    v.size(), cancel, 0.0,
                    [&](size_t begin, size_t end) {
                      double part = 0;
                      for (size_t i = begin; i < end; ++i) part += v[i];
                      return part;
                    },
                    sum, kGrain)
                    .ok());
  });
  return sum;
}

TEST(ParallelSum, IsTheBlockOrderedSumOnAnyNumberOfThreads) {
  const std::vector<double> v = OrderSensitive(25 * kGrain);
  // Ground truth: the blocks' sums added in block order, serially.
  double expected = 0;
  for (size_t b = 0; b < v.size(); b += kGrain) {
    double part = 0;
    for (size_t i = b; i < std::min(v.size(), b + kGrain); ++i) part += v[i];
    expected += part;
  }
  // Control: the same blocks added in reverse order give another double, so the equality below
  // is not luck.
  double other = 0;
  for (size_t b = (v.size() - 1) / kGrain + 1; b-- > 0;) {
    double part = 0;
    for (size_t i = b * kGrain; i < std::min(v.size(), (b + 1) * kGrain); ++i) part += v[i];
    other += part;
  }
  ASSERT_NE(other, expected);
  for (const int threads : {1, 2, 4}) EXPECT_EQ(SumOn(threads, v), expected) << threads;
}

TEST(ParallelSum, StopsWithCancelledWhenAsked) {
  CancelToken cancel;
  cancel.Cancel();
  double sum = 1;
  const absl::Status status = ParallelSum(
      size_t{100000}, cancel, 0.0, [](size_t begin, size_t end) { return double(end - begin); },
      sum);
  EXPECT_EQ(status.code(), absl::StatusCode::kCancelled);
}

TEST(ValuesPerScan, EveryValueReachesItsScanOnceOnAnyNumberOfThreads) {
  PointCloud cloud;
  const size_t n = 100003;
  cloud.scans.resize(3);
  std::mt19937 rng(3);
  for (size_t i = 0; i < n; ++i) cloud.scan.push_back(static_cast<uint32_t>(rng() % 3));
  // Point i gives the value i when i is not a multiple of 7.
  std::vector<std::vector<float>> expected(3);
  for (size_t i = 0; i < n; ++i) {
    if (i % 7 != 0) expected[cloud.scan[i]].push_back(float(i));
  }
  for (const int threads : {1, 2, 4}) {
    CancelToken cancel;
    absl::StatusOr<std::vector<std::vector<float>>> got;
    tbb::task_arena(threads).execute([&] {
      got = ValuesPerScan(cloud, n, cancel, [&](size_t i, const auto& add) {
        if (i % 7 != 0) add(cloud.scan[i], float(i));
      });
    });
    ASSERT_TRUE(got.ok());
    ASSERT_EQ(got->size(), 3u);
    for (size_t s = 0; s < 3; ++s) {
      std::vector<float> values = (*got)[s];
      std::sort(values.begin(), values.end());
      EXPECT_EQ(values, expected[s]) << "scan " << s << ", " << threads << " threads";
    }
  }
  CancelToken cancelled;
  cancelled.Cancel();
  EXPECT_EQ(ValuesPerScan(cloud, n, cancelled, [](size_t, const auto&) {}).status().code(),
            absl::StatusCode::kCancelled);
}

}  // namespace
}  // namespace scanprep
