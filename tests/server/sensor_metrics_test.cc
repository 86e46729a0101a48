// SPDX-License-Identifier: Apache-2.0
// Per-sensor health metrics (server/sensor_metrics.h): a hand-made HealthReport recorded into a
// registry, read back from its text exposition as Prometheus would scrape it; and a job of two
// simulated sensors through the service, its /metrics scraped.
#include <string>

#include <gtest/gtest.h>

#include "client/cli_args.h"
#include "client/job_builder.h"
#include "core/sim/scan_simulator.h"
#include "server/metrics/sensor_metrics.h"
#include "tests/server/metrics_scrape.h"
#include "tests/server/service_fixtures.h"

namespace scanprep::server {
namespace {

using scanprep::testing::ParseSamples;

ScanHealth Scan(uint32_t index, const std::string& sensor, double noise_mm) {
  ScanHealth scan;
  scan.scan = index;
  scan.scan_id = "scan" + std::to_string(index);
  scan.sensor_id = sensor;
  scan.noise_mm = noise_mm;
  return scan;
}

struct Recorder {
  explicit Recorder(SensorMetricsOptions options = {}) : sensors(registry, options) {}
  std::map<std::string, double> Samples() const { return ParseSamples(registry.Serialize()); }
  metrics::Registry registry;
  SensorMetrics sensors;
};

TEST(SensorMetrics, AJobsHealthIsExportedPerSensorAndPair) {
  Recorder r({.max_sensors = 8, .tolerance_mm = 0.02, .rotation_tolerance_deg = 0.01});
  HealthReport health;
  health.scans = {Scan(0, "cell3-left", 0.010), Scan(1, "cell3-right", 0.030),
                  Scan(2, "cell3-left", 0.014), Scan(3, "", 0.5)};
  health.scans[0].noise_to_uncertainty = 1.0;
  health.scans[0].outlier_share = 0.02;
  health.scans[2].outlier_share = 0.04;  // no u stated: not in the ratio's mean
  PairHealth pair;
  pair.fixed = 0;
  pair.moving = 1;
  pair.residual_median_mm = -0.006;
  pair.residual_spread_mm = 0.012;
  pair.translation_mm = {0.003, 0, 0.004};
  pair.rotation_deg = {0, 0.02, 0};
  PairHealth unnamed = pair;  // scan 3 has no sensor id: not exported
  unnamed.moving = 3;
  health.pairs = {pair, unnamed};
  r.sensors.Record(health, 1'700'000'000);

  const auto s = r.Samples();
  // Two scans of cell3-left: the mean of what was measured.
  EXPECT_DOUBLE_EQ(s.at("scanprep_sensor_noise_mm{sensor=\"cell3-left\"}"), 0.012);
  EXPECT_DOUBLE_EQ(s.at("scanprep_sensor_noise_mm{sensor=\"cell3-right\"}"), 0.030);
  EXPECT_DOUBLE_EQ(s.at("scanprep_sensor_noise_to_uncertainty_ratio{sensor=\"cell3-left\"}"), 1.0);
  EXPECT_FALSE(s.contains("scanprep_sensor_noise_to_uncertainty_ratio{sensor=\"cell3-right\"}"));
  EXPECT_DOUBLE_EQ(s.at("scanprep_sensor_outlier_ratio{sensor=\"cell3-left\"}"), 0.03);
  EXPECT_DOUBLE_EQ(s.at("scanprep_sensor_scans_total{sensor=\"cell3-left\"}"), 2);
  EXPECT_DOUBLE_EQ(s.at("scanprep_sensor_last_report_timestamp_seconds{sensor=\"cell3-right\"}"),
                   1'700'000'000);
  const std::string pair_key = "{sensor_pair=\"cell3-left|cell3-right\"}";
  EXPECT_DOUBLE_EQ(s.at("scanprep_sensor_pair_residual_median_mm" + pair_key), -0.006);
  EXPECT_DOUBLE_EQ(s.at("scanprep_sensor_pair_residual_spread_mm" + pair_key), 0.012);
  EXPECT_DOUBLE_EQ(s.at("scanprep_sensor_pair_translation_mm" + pair_key), 0.005);
  EXPECT_DOUBLE_EQ(s.at("scanprep_sensor_pair_rotation_degrees" + pair_key), 0.02);
  EXPECT_DOUBLE_EQ(s.at("scanprep_sensor_tolerance_mm"), 0.02);
  EXPECT_DOUBLE_EQ(s.at("scanprep_sensor_rotation_tolerance_degrees"), 0.01);
  EXPECT_DOUBLE_EQ(s.at("scanprep_sensor_labels_folded_total"), 0);
  // The scan without a sensor id is in no series: only the two sensors and their one pair.
  int sensor_series = 0, pair_series = 0;
  for (const auto& [key, value] : s) {
    sensor_series += key.starts_with("scanprep_sensor_noise_mm{");
    pair_series += key.starts_with("scanprep_sensor_pair_residual_median_mm{");
  }
  EXPECT_EQ(sensor_series, 2);
  EXPECT_EQ(pair_series, 1);
}

// --max_sensors 2: the third distinct sensor, in a later job, folds into "other" and is counted;
// the first two keep their labels, and a pair with the folded sensor folds too.
TEST(SensorMetrics, SensorsBeyondTheCapFoldIntoOther) {
  Recorder r({.max_sensors = 2});
  HealthReport first;
  first.scans = {Scan(0, "a", 0.01), Scan(1, "b", 0.02)};
  r.sensors.Record(first, 100);
  HealthReport second;
  second.scans = {Scan(0, "c", 0.05), Scan(1, "a", 0.011), Scan(2, "c", 0.07)};
  PairHealth pair;
  pair.fixed = 1;
  pair.moving = 2;
  pair.residual_median_mm = 0.1;
  second.pairs = {pair};
  r.sensors.Record(second, 200);

  const auto s = r.Samples();
  EXPECT_DOUBLE_EQ(s.at("scanprep_sensor_noise_mm{sensor=\"a\"}"), 0.011);
  EXPECT_DOUBLE_EQ(s.at("scanprep_sensor_noise_mm{sensor=\"b\"}"), 0.02);
  EXPECT_FALSE(s.contains("scanprep_sensor_noise_mm{sensor=\"c\"}"));
  EXPECT_DOUBLE_EQ(s.at("scanprep_sensor_noise_mm{sensor=\"other\"}"), 0.06);
  EXPECT_DOUBLE_EQ(s.at("scanprep_sensor_labels_folded_total"), 2);  // c's two scans
  EXPECT_DOUBLE_EQ(s.at("scanprep_sensor_last_report_timestamp_seconds{sensor=\"other\"}"), 200);
  EXPECT_DOUBLE_EQ(s.at("scanprep_sensor_last_report_timestamp_seconds{sensor=\"b\"}"), 100);
  EXPECT_DOUBLE_EQ(s.at("scanprep_sensor_pair_residual_median_mm{sensor_pair=\"other\"}"), 0.1);
  EXPECT_FALSE(s.contains("scanprep_sensor_pair_residual_median_mm{sensor_pair=\"a|other\"}"));
}

// Label values come only from sensor_id and are sanitised again here, whatever reached the core:
// nothing a client sends can break out of the label's quotes or grow it past 64 bytes.
TEST(SensorMetrics, LabelValuesAreSanitised) {
  Recorder r;
  HealthReport health;
  health.scans = {Scan(0, "x\"} 1\nevil_metric 2", 0.01), Scan(1, std::string(100, 'z'), 0.02)};
  r.sensors.Record(health, 1);
  const auto s = r.Samples();
  EXPECT_DOUBLE_EQ(s.at("scanprep_sensor_noise_mm{sensor=\"x___1_evil_metric_2\"}"), 0.01);
  EXPECT_DOUBLE_EQ(s.at("scanprep_sensor_noise_mm{sensor=\"" + std::string(64, 'z') + "\"}"), 0.02);
  EXPECT_FALSE(s.contains("evil_metric"));
}

// The service's path: ServerOptions.sensor_metrics (the flags) reach the registry, and a job's
// health reaches /metrics. Two overlapping sensors (the oblique one twice as noisy); with
// --max_sensors 1 the second sensor and the pair fold into "other".
std::map<std::string, double> ScrapeAfterTwoSensorJob(int max_sensors) {
  server::ServerOptions options;
  options.metrics_listen = "127.0.0.1:0";
  options.sensor_metrics = {.max_sensors = max_sensors, .tolerance_mm = 0.03};
  scanprep::testing::InProcessServer server(options);
  sim::SimulatedCloud scan = sim::SimulateWithPointCount(
      sim::Part::kPlane, sim::TwoOverlappingSensors(sim::Part::kPlane), 20'000, 0.01, 7);
  scan.cloud.scans[0].sensor_id = "front";
  scan.cloud.scans[1].sensor_id = "oblique";
  auto args = client::ParseArgs({}, client::JobFlags());
  EXPECT_TRUE(args.ok()) << args.status();
  auto job = client::BuildJobFromCloud(*args, std::move(scan.cloud));
  EXPECT_TRUE(job.ok()) << job.status();
  auto result = server.Client().Process(job->header, job->points);
  EXPECT_TRUE(result.ok()) << result.status();
  return scanprep::testing::Scrape(server.server().metrics_port());
}

TEST(SensorMetrics, AJobThroughTheServiceIsExportedPerSensor) {
  const auto s = ScrapeAfterTwoSensorJob(64);
  EXPECT_DOUBLE_EQ(s.at("scanprep_sensor_tolerance_mm"), 0.03);
  EXPECT_DOUBLE_EQ(s.at("scanprep_sensor_scans_total{sensor=\"front\"}"), 1);
  EXPECT_DOUBLE_EQ(s.at("scanprep_sensor_scans_total{sensor=\"oblique\"}"), 1);
  // The simulator's truth: 0.01 mm of noise on the frontal sensor, and the oblique one displaced
  // by 0.02 mm (TwoOverlappingSensors).
  EXPECT_NEAR(s.at("scanprep_sensor_noise_mm{sensor=\"front\"}"), 0.01, 0.002);
  EXPECT_NEAR(s.at("scanprep_sensor_pair_translation_mm{sensor_pair=\"front|oblique\"}"), 0.02,
              0.005);
  EXPECT_TRUE(s.contains("scanprep_sensor_pair_residual_median_mm{sensor_pair=\"front|oblique\"}"));
  EXPECT_DOUBLE_EQ(s.at("scanprep_sensor_labels_folded_total"), 0);
}

TEST(SensorMetrics, TheServersCapFoldsTheSecondSensor) {
  const auto s = ScrapeAfterTwoSensorJob(1);
  EXPECT_DOUBLE_EQ(s.at("scanprep_sensor_scans_total{sensor=\"front\"}"), 1);
  EXPECT_FALSE(s.contains("scanprep_sensor_scans_total{sensor=\"oblique\"}"));
  EXPECT_DOUBLE_EQ(s.at("scanprep_sensor_scans_total{sensor=\"other\"}"), 1);
  EXPECT_DOUBLE_EQ(s.at("scanprep_sensor_labels_folded_total"), 1);
  EXPECT_TRUE(s.contains("scanprep_sensor_pair_residual_median_mm{sensor_pair=\"other\"}"));
}

TEST(SensorMetrics, OptionsAreChecked) {
  EXPECT_TRUE(CheckSensorMetricsOptions({}).ok());
  EXPECT_FALSE(CheckSensorMetricsOptions({.max_sensors = -1}).ok());
  EXPECT_FALSE(CheckSensorMetricsOptions({.tolerance_mm = 0}).ok());
  EXPECT_FALSE(CheckSensorMetricsOptions({.rotation_tolerance_deg = std::nan("")}).ok());
}

}  // namespace
}  // namespace scanprep::server
