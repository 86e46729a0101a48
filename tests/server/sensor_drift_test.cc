// SPDX-License-Identifier: Apache-2.0
// Issue 32's end-to-end check of the drift alert: a replayed series of jobs of one simulated
// sensor goes through the real service, whose /metrics is read after each job; the sensor's noise
// gauge, replayed one job per minute, is handed to `promtool test rules` with the shipped
// deploy/prometheus/alerts.yml. When the sensor's noise doubles halfway, ScanprepSensorNoiseDrift
// fires; the control, the same jobs without the step, stays quiet. Skipped without promtool.
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "client/cli_args.h"
#include "client/job_builder.h"
#include "core/sim/scan_simulator.h"
#include "tests/server/metrics_scrape.h"
#include "tests/server/service_fixtures.h"
#include "tests/support/run_command.h"

namespace scanprep::testing {
namespace {

namespace fs = std::filesystem;

constexpr char kSensor[] = "cell1-top";
constexpr double kNoiseMm = 0.01;      // the sensor's simulated range noise before the step
constexpr int kJobsPerLevel = 30;      // replayed one a minute: 30 min before the step, 30 after
constexpr int kHistoryMinutes = 1380;  // the day before the replay, so the 24 h window is full

// One job of the sensor: a plane seen frontally with `noise_mm` of range noise and 1 % spikes.
// The stated u stays what the datasheet says whatever the noise does.
client::Job SensorJob(double noise_mm, uint64_t seed) {
  std::vector<sim::SimSensor> sensors = sim::FrontalSensor(sim::Part::kPlane);
  sensors[0].noise_sigma = noise_mm;
  sim::SimulatedCloud scan =
      sim::SimulateWithPointCount(sim::Part::kPlane, sensors, 8'000, 0.01, seed);
  scan.cloud.scans[0].sensor_id = kSensor;
  scan.cloud.scans[0].uncertainty = 3 * kNoiseMm;
  auto args = client::ParseArgs({}, client::JobFlags());
  EXPECT_TRUE(args.ok()) << args.status();
  auto job = client::BuildJobFromCloud(*args, std::move(scan.cloud));
  EXPECT_TRUE(job.ok()) << job.status();
  return *std::move(job);
}

// The sensor's noise gauge after each job of the replay: the first kJobsPerLevel jobs at
// kNoiseMm, the rest at `step` times it.
std::vector<double> ReplayedNoise(double step) {
  server::ServerOptions options;
  options.metrics_listen = "127.0.0.1:0";
  InProcessServer server(options);
  const std::string key = absl::StrCat("scanprep_sensor_noise_mm{sensor=\"", kSensor, "\"}");
  std::vector<double> noise;
  for (int i = 0; i < 2 * kJobsPerLevel; ++i) {
    const double level = i < kJobsPerLevel ? kNoiseMm : step * kNoiseMm;
    const client::Job job = SensorJob(level, 100 + i);
    auto result = server.Client().Process(job.header, job.points);
    EXPECT_TRUE(result.ok()) << result.status();
    if (!result.ok()) return {};
    noise.push_back(Sample(server.server().metrics_port(), key));
    // What the server exported is what the job's own report measured.
    EXPECT_TRUE(result->report.has_health());
    if (result->report.health().scans_size() == 1) {
      EXPECT_DOUBLE_EQ(noise.back(), result->report.health().scans(0).noise_mm());
    }
  }
  return noise;
}

// The replay as a promtool series, one job a minute, after a day of history that cycles through
// the replay's first (pre-step) values.
std::string PromtoolValues(const std::vector<double>& noise) {
  std::vector<std::string> values;
  for (int m = 0; m < kHistoryMinutes; ++m) {
    values.push_back(absl::StrCat(noise[m % kJobsPerLevel]));
  }
  for (double v : noise) values.push_back(absl::StrCat(v));
  return absl::StrJoin(values, " ");
}

// `promtool test rules` on the shipped rules with the replay; `firing_at` are the evaluation
// minutes (from the replay's start) at which the drift alert must fire, `quiet_at` where not.
CommandResult RunPromtool(const std::vector<double>& noise, const std::vector<int>& firing_at,
                          const std::vector<int>& quiet_at, const std::string& name) {
  const fs::path path = fs::path(::testing::TempDir()) / (name + "_alerts_test.yml");
  std::ofstream out(path);
  out << "rule_files:\n  - " << SCANPREP_ALERT_RULES << "\n"
      << "evaluation_interval: 1m\ntests:\n  - interval: 1m\n    input_series:\n"
      << "      - series: 'scanprep_sensor_noise_mm{instance=\"replay\",sensor=\"" << kSensor
      << "\"}'\n        values: '" << PromtoolValues(noise) << "'\n"
      << "      - series: "
         "'scanprep_sensor_last_report_timestamp_seconds{instance=\"replay\",sensor=\""
      << kSensor << "\"}'\n        values: '0+60x" << kHistoryMinutes + noise.size() - 1 << "'\n"
      << "    alert_rule_test:\n";
  for (int minute : quiet_at) {
    out << "      - eval_time: " << kHistoryMinutes + minute << "m\n"
        << "        alertname: ScanprepSensorNoiseDrift\n        exp_alerts: []\n";
  }
  for (int minute : firing_at) {
    out << "      - eval_time: " << kHistoryMinutes + minute << "m\n"
        << "        alertname: ScanprepSensorNoiseDrift\n        exp_alerts:\n"
        << "          - exp_labels:\n              severity: warning\n"
        << "              sensor: " << kSensor << "\n"
        << "            exp_annotations:\n"
        << "              summary: \"sensor " << kSensor
        << "'s noise is above 1.5x its 24 h median\"\n"
        << "              description: \"Its last job measured a noise of "
        << absl::StrFormat("%.3g", noise[minute]) << " mm.\"\n"
        << "              runbook_url: "
           "\"https://scanprep.example.com/docs/deployment.md#scanprepsensornoisedrift\"\n";
  }
  out.close();
  return RunCommand(absl::StrCat(SCANPREP_PROMTOOL, " test rules ", path.string(), " 2>&1"));
}

TEST(SensorDrift, ANoiseStepOverReplayedJobsFiresTheDriftAlertAndTheControlStaysQuiet) {
  if (std::string(SCANPREP_PROMTOOL).empty()) GTEST_SKIP() << "promtool is not installed";
  const std::vector<double> stepped = ReplayedNoise(2.0);
  const std::vector<double> control = ReplayedNoise(1.0);
  ASSERT_EQ(stepped.size(), 2u * kJobsPerLevel);
  ASSERT_EQ(control.size(), 2u * kJobsPerLevel);
  // The measured noise follows the simulated one: the step is a doubling, give or take the
  // estimate's scatter (ground truth: the simulator's sigma).
  for (int i = 0; i < 2 * kJobsPerLevel; ++i) {
    const double simulated = i < kJobsPerLevel ? kNoiseMm : 2 * kNoiseMm;
    EXPECT_NEAR(stepped[i] / simulated, 1.0, 0.15) << "job " << i << ": " << stepped[i];
    EXPECT_NEAR(control[i] / kNoiseMm, 1.0, 0.15) << "job " << i << ": " << control[i];
  }

  // The step comes at minute 30: pending until 45, firing to the end.
  const int last = 2 * kJobsPerLevel - 1;
  const CommandResult fires = RunPromtool(stepped, {50, last}, {kJobsPerLevel - 1, 40}, "stepped");
  EXPECT_EQ(fires.exit_code, 0) << fires.output;
  const CommandResult quiet =
      RunPromtool(control, {}, {kJobsPerLevel - 1, 40, 50, last}, "control");
  EXPECT_EQ(quiet.exit_code, 0) << quiet.output;
  // promtool itself can fail: the control series where the step's alert is expected.
  const CommandResult wrong = RunPromtool(control, {last}, {}, "control_expected_to_fire");
  EXPECT_NE(wrong.exit_code, 0) << wrong.output;
}

}  // namespace
}  // namespace scanprep::testing
