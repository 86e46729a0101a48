// SPDX-License-Identifier: Apache-2.0
// The registry's text must be exact Prometheus exposition format 0.0.4: checked line by line and,
// when promtool is installed, by `promtool check metrics`.
#include <cstdio>
#include <string>

#include <gtest/gtest.h>

#include "server/metrics/registry.h"

namespace scanprep::metrics {
namespace {

TEST(MetricsRegistry, RendersCountersGaugesHistogramsExactly) {
  Registry registry;
  auto& rpcs = registry.AddCounter("scanprep_rpcs_total", "RPCs handled.", {"method", "code"});
  rpcs.WithLabels({"Process", "OK"}).Inc();
  rpcs.WithLabels({"Process", "OK"}).Inc(2);
  rpcs.WithLabels({"GetInfo", "INVALID_ARGUMENT"}).Inc();
  registry.AddGauge("scanprep_jobs_in_flight", "Jobs running.").WithLabels({}).Set(3);
  auto& seconds =
      registry.AddHistogram("scanprep_stage_duration_seconds", "Stage time.", {0.1, 1}, {"stage"});
  seconds.WithLabels({"smoothing"}).Observe(0.05);
  seconds.WithLabels({"smoothing"}).Observe(0.5);
  seconds.WithLabels({"smoothing"}).Observe(7);

  EXPECT_EQ(registry.Serialize(),
            "# HELP scanprep_rpcs_total RPCs handled.\n"
            "# TYPE scanprep_rpcs_total counter\n"
            "scanprep_rpcs_total{method=\"GetInfo\",code=\"INVALID_ARGUMENT\"} 1\n"
            "scanprep_rpcs_total{method=\"Process\",code=\"OK\"} 3\n"
            "# HELP scanprep_jobs_in_flight Jobs running.\n"
            "# TYPE scanprep_jobs_in_flight gauge\n"
            "scanprep_jobs_in_flight 3\n"
            "# HELP scanprep_stage_duration_seconds Stage time.\n"
            "# TYPE scanprep_stage_duration_seconds histogram\n"
            "scanprep_stage_duration_seconds_bucket{stage=\"smoothing\",le=\"0.1\"} 1\n"
            "scanprep_stage_duration_seconds_bucket{stage=\"smoothing\",le=\"1\"} 2\n"
            "scanprep_stage_duration_seconds_bucket{stage=\"smoothing\",le=\"+Inf\"} 3\n"
            "scanprep_stage_duration_seconds_sum{stage=\"smoothing\"} 7.55\n"
            "scanprep_stage_duration_seconds_count{stage=\"smoothing\"} 3\n");
}

TEST(MetricsRegistry, EscapesHelpAndLabelValues) {
  Registry registry;
  registry.AddCounter("x_total", "a \\ b\nc", {"l"}).WithLabels({"q\"\\\n"}).Inc();
  EXPECT_EQ(registry.Serialize(),
            "# HELP x_total a \\\\ b\\nc\n"
            "# TYPE x_total counter\n"
            "x_total{l=\"q\\\"\\\\\\n\"} 1\n");
}

TEST(MetricsRegistry, BucketBoundIsInclusive) {
  Histogram h({1.0, 2.0});
  h.Observe(1.0);
  h.Observe(2.5);
  const auto s = h.snapshot();
  EXPECT_EQ(s.cumulative, (std::vector<uint64_t>{1, 1, 2}));
  EXPECT_DOUBLE_EQ(s.sum, 3.5);
}

TEST(MetricsRegistry, ProcessMetricsPassPromtool) {
  Registry registry;
  AddProcessMetrics(registry);
  registry
      .AddHistogram("scanprep_job_duration_seconds", "Job time.", ExponentialBuckets(0.01, 2, 12))
      .WithLabels({})
      .Observe(0.3);
  const std::string text = registry.Serialize();
  EXPECT_NE(text.find("process_resident_memory_bytes "), std::string::npos);
  EXPECT_EQ(text.find("process_resident_memory_bytes 0\n"), std::string::npos);
  EXPECT_EQ(text.find("process_start_time_seconds 0\n"), std::string::npos);
  if (std::system("command -v promtool >/dev/null 2>&1") != 0) {
    GTEST_SKIP() << "promtool not installed (Debian package 'prometheus')";
  }
  FILE* pipe = popen("promtool check metrics > /dev/null 2>&1", "w");
  ASSERT_NE(pipe, nullptr);
  fwrite(text.data(), 1, text.size(), pipe);
  EXPECT_EQ(pclose(pipe), 0) << text;
}

}  // namespace
}  // namespace scanprep::metrics
