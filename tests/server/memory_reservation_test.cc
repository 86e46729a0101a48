// SPDX-License-Identifier: Apache-2.0
// The memory-aware admission's arithmetic: a job's estimate from its point count and k, the
// automatic capacity from a container limit or the RAM, and the startup check of
// --max_points_per_job against it. Expected values are worked out by hand from the constants.
#include "server/admission/memory_reservation.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace scanprep::server {
namespace {

using ::testing::HasSubstr;

constexpr uint64_t kMiB = uint64_t{1} << 20;
constexpr uint64_t kGiB = uint64_t{1} << 30;

TEST(MemoryEstimate, IsTheFixedOverheadPlusTheBytesPerPointOfItsK) {
  EXPECT_EQ(EstimateJobBytes(1'000'000, {}), 16 * kMiB + 416'000'000);
  // k = 64: 44 neighbours above the default at 8 B each.
  EXPECT_EQ(BytesPerPoint({{"neighbourhoods.k", "64"}}), 416u + 44 * 8);
  EXPECT_EQ(EstimateJobBytes(1'000'000, {{"neighbourhoods.k", "64"}}), 16 * kMiB + 768'000'000);
  // A smaller k is estimated like the default, never below it.
  EXPECT_EQ(BytesPerPoint({{"neighbourhoods.k", "3"}}), 416u);
  EXPECT_EQ(BytesPerPoint({{"outliers.multiplier", "2.5"}}), 416u);
}

TEST(MemoryEstimate, CoversTheWorstMeasuredPeaksWithAMargin) {
  // The measurements in memory_reservation.h (B/point above the idle server): the worst default-k
  // run (balls at their cap) and the worst k = 64 run.
  EXPECT_GE(BytesPerPoint({}), 308 * 1.3);
  EXPECT_GE(BytesPerPoint({{"neighbourhoods.k", "64"}}), 491 * 1.3);
}

TEST(AutoMemoryCapacity, IsTheContainerLimitMinusTheServersReserve) {
  auto capacity = AutoMemoryCapacity(2 * kGiB, 24 * kGiB);
  ASSERT_TRUE(capacity.ok()) << capacity.status();
  EXPECT_EQ(capacity->bytes, 2 * kGiB - 128 * kMiB);
  EXPECT_THAT(capacity->source, HasSubstr("container's memory limit 2048 MiB minus 128 MiB"));
}

TEST(AutoMemoryCapacity, WithoutAContainerLimitIsHalfTheRam) {
  auto capacity = AutoMemoryCapacity(std::nullopt, 24 * kGiB);
  ASSERT_TRUE(capacity.ok()) << capacity.status();
  EXPECT_EQ(capacity->bytes, 12 * kGiB);
  EXPECT_THAT(capacity->source, HasSubstr("no container memory limit"));
  // cgroup v1 states "no limit" as a huge number: a limit not below the RAM is none.
  capacity = AutoMemoryCapacity(uint64_t{9223372036854771712u}, 24 * kGiB);
  ASSERT_TRUE(capacity.ok());
  EXPECT_EQ(capacity->bytes, 12 * kGiB);
}

TEST(AutoMemoryCapacity, FailsWhenTheLimitLeavesNothingAfterTheReserve) {
  auto capacity = AutoMemoryCapacity(100 * kMiB, 24 * kGiB);
  EXPECT_EQ(capacity.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(capacity.status().message(), HasSubstr("limit of 100 MiB leaves nothing"));
  EXPECT_FALSE(AutoMemoryCapacity(std::nullopt, 0).ok());
}

TEST(ParseCgroupLimit, ReadsBytesAndTreatsMaxAsNoLimit) {
  EXPECT_EQ(ParseCgroupLimit("2147483648\n"), 2147483648u);
  EXPECT_EQ(ParseCgroupLimit("max\n"), std::nullopt);
  EXPECT_EQ(ParseCgroupLimit(""), std::nullopt);
}

TEST(ResolveMemoryLimits, DefaultsTheLargestJobToWhatFitsTheCapacity) {
  // The shipped pod: a 2 GiB limit gives 1920 MiB; one job of (1920 - 16) MiB / 416 B.
  auto limits = ResolveMemoryLimits(2 * kGiB - 128 * kMiB, 0);
  ASSERT_TRUE(limits.ok()) << limits.status();
  EXPECT_EQ(limits->max_points_per_job, (1904 * kMiB) / 416);
  EXPECT_EQ(limits->capacity.source, "--memory_capacity");
  // A large capacity keeps the 20 M default.
  limits = ResolveMemoryLimits(64 * kGiB, 0);
  ASSERT_TRUE(limits.ok());
  EXPECT_EQ(limits->max_points_per_job, 20'000'000u);
  // An explicit limit that fits stays.
  limits = ResolveMemoryLimits(kGiB, 1'000'000);
  ASSERT_TRUE(limits.ok());
  EXPECT_EQ(limits->max_points_per_job, 1'000'000u);
}

TEST(ResolveMemoryLimits, RefusesAJobLimitTheCapacityCannotMeet) {
  auto limits = ResolveMemoryLimits(kGiB, 20'000'000);
  EXPECT_EQ(limits.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(
      limits.status().message(),
      HasSubstr("--max_points_per_job=20000000 needs an estimated 7951 MiB (16 MiB + "
                "416 B/point), more than the memory capacity of 1024 MiB (--memory_capacity)"));
  EXPECT_THAT(limits.status().message(),
              HasSubstr("at most " + std::to_string((kGiB - 16 * kMiB) / 416)));
  limits = ResolveMemoryLimits(kMiB, 0);
  EXPECT_EQ(limits.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(limits.status().message(), HasSubstr("leaves no room for a job"));
}

TEST(ResolveMemoryLimits, RefusesMorePointsThanAJobCanIndex) {
  // Enough memory for them (416 B/point), but upload positions are 32-bit: the control, one
  // point fewer, is accepted.
  const uint64_t capacity = uint64_t{2} << 40;
  auto limits = ResolveMemoryLimits(capacity, kMaxIndexablePoints + 1);
  EXPECT_EQ(limits.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(limits.status().message(), HasSubstr("the most points a job can index"));
  EXPECT_TRUE(ResolveMemoryLimits(capacity, kMaxIndexablePoints).ok());
}

}  // namespace
}  // namespace scanprep::server
