// SPDX-License-Identifier: Apache-2.0
// Per-sensor health metrics (server/sensor_metrics.h): a hand-made HealthReport recorded into a
// registry, read back from its text exposition as Prometheus would scrape it; and a job of two
// simulated sensors through the service, its /metrics scraped.
#include <cstdio>
#include <limits>
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
  // ty is unconstrained: its error, the largest, is not the translation's.
  pair.constrained = {true, false, true, true, true, false};
  pair.translation_se_mm = {0.0002, 0.05, 0.0001};
  pair.rotation_se_deg = {0.001, 0.003, std::numeric_limits<double>::infinity()};
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
  EXPECT_DOUBLE_EQ(s.at("scanprep_sensor_pair_translation_standard_error_mm" + pair_key), 0.0002);
  EXPECT_DOUBLE_EQ(s.at("scanprep_sensor_pair_rotation_standard_error_degrees" + pair_key), 0.003);
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

// --max_sensors 2: a third sensor, in a later job, takes the label of the least recently
// reported one (b; a reported again since), whose series go; a pair with it is labelled too.
TEST(SensorMetrics, ANewSensorTakesTheLeastRecentlyReportedLabel) {
  Recorder r({.max_sensors = 2});
  HealthReport first;
  first.scans = {Scan(0, "a", 0.01), Scan(1, "b", 0.02)};
  r.sensors.Record(first, 100);
  HealthReport again;
  again.scans = {Scan(0, "a", 0.011)};
  r.sensors.Record(again, 150);
  HealthReport third;
  third.scans = {Scan(0, "c", 0.05), Scan(1, "a", 0.012), Scan(2, "c", 0.07)};
  PairHealth pair;
  pair.fixed = 1;
  pair.moving = 2;
  pair.residual_median_mm = 0.1;
  third.pairs = {pair};
  r.sensors.Record(third, 200);

  const auto s = r.Samples();
  EXPECT_DOUBLE_EQ(s.at("scanprep_sensor_noise_mm{sensor=\"a\"}"), 0.012);
  EXPECT_DOUBLE_EQ(s.at("scanprep_sensor_noise_mm{sensor=\"c\"}"), 0.06);
  EXPECT_FALSE(s.contains("scanprep_sensor_noise_mm{sensor=\"b\"}"));
  EXPECT_FALSE(s.contains("scanprep_sensor_last_report_timestamp_seconds{sensor=\"b\"}"));
  EXPECT_FALSE(s.contains("scanprep_sensor_noise_mm{sensor=\"other\"}"));
  EXPECT_DOUBLE_EQ(s.at("scanprep_sensor_scans_total{sensor=\"c\"}"), 2);
  EXPECT_DOUBLE_EQ(s.at("scanprep_sensor_labels_evicted_total"), 1);
  EXPECT_DOUBLE_EQ(s.at("scanprep_sensor_labels_folded_total"), 0);
  EXPECT_DOUBLE_EQ(s.at("scanprep_sensor_pair_residual_median_mm{sensor_pair=\"a|c\"}"), 0.1);
}

// One job of `count` scans, each of its own sensor `prefix`0, `prefix`1, ..., every scan paired
// with the next `pairs_per_scan` ones (health keeps up to 256 pairs a job).
HealthReport JobOfSensors(const std::string& prefix, int count, int pairs_per_scan = 0) {
  HealthReport health;
  for (int i = 0; i < count; ++i) {
    health.scans.push_back(Scan(i, prefix + std::to_string(i), 0.01 + 0.001 * i));
  }
  for (int i = 0; i < count; ++i) {
    for (int j = i + 1; j <= i + pairs_per_scan && j < count; ++j) {
      PairHealth pair;
      pair.fixed = i;
      pair.moving = j;
      pair.residual_median_mm = 0.001 * j;
      health.pairs.push_back(pair);
    }
  }
  return health;
}

// The series of `metric` in a scrape, and those whose labels contain `part`.
int CountSeries(const std::map<std::string, double>& samples, const std::string& metric,
                const std::string& part = "") {
  int count = 0;
  for (const auto& [key, value] : samples) {
    count += key.starts_with(metric + "{") && key.find(part) != std::string::npos;
  }
  return count;
}

// Issue 39 finding 6: a client that sent 64 sensor ids held every label for the server's
// lifetime, and the plant's cell3-left, reported after, was folded into "other" forever. Labels
// go by recency now: cell3-left takes the slot of the least recently reported squatter.
TEST(SensorMetrics, ASensorReportedAfterASquatterFloodGetsItsLabel) {
  Recorder r;  // the defaults: 64 sensors
  r.sensors.Record(JobOfSensors("squat", 64), 100);
  HealthReport real;
  real.scans = {Scan(0, "cell3-left", 0.02)};
  r.sensors.Record(real, 200);

  const auto s = r.Samples();
  EXPECT_DOUBLE_EQ(s.at("scanprep_sensor_noise_mm{sensor=\"cell3-left\"}"), 0.02);
  EXPECT_FALSE(s.contains("scanprep_sensor_noise_mm{sensor=\"other\"}"));
  // squat0 was reported least recently (the first scan of the job): its series are gone.
  EXPECT_FALSE(s.contains("scanprep_sensor_noise_mm{sensor=\"squat0\"}"));
  EXPECT_FALSE(s.contains("scanprep_sensor_scans_total{sensor=\"squat0\"}"));
  EXPECT_TRUE(s.contains("scanprep_sensor_noise_mm{sensor=\"squat1\"}"));
  EXPECT_EQ(CountSeries(s, "scanprep_sensor_noise_mm"), 64);
  EXPECT_DOUBLE_EQ(s.at("scanprep_sensor_labels_evicted_total"), 1);
}

// A job with more sensors than slots cannot evict its own: the ones past the cap fold into
// "other", as before, and are counted.
TEST(SensorMetrics, AJobsOwnSensorsAreNotEvictedForEachOther) {
  Recorder r({.max_sensors = 2});
  r.sensors.Record(JobOfSensors("s", 3), 100);
  const auto s = r.Samples();
  EXPECT_TRUE(s.contains("scanprep_sensor_noise_mm{sensor=\"s0\"}"));
  EXPECT_TRUE(s.contains("scanprep_sensor_noise_mm{sensor=\"s1\"}"));
  EXPECT_DOUBLE_EQ(s.at("scanprep_sensor_noise_mm{sensor=\"other\"}"), 0.012);
  EXPECT_DOUBLE_EQ(s.at("scanprep_sensor_labels_folded_total"), 1);
  EXPECT_DOUBLE_EQ(s.at("scanprep_sensor_labels_evicted_total"), 0);
}

// --sensor_allowlist: the listed sensor keeps its label and its last value through any flood of
// other ids, which share the --max_sensors slots among themselves; with --max_sensors 0 only the
// listed sensors have labels.
TEST(SensorMetrics, AllowListedSensorsAreNeverEvicted) {
  Recorder r({.max_sensors = 2, .sensor_allowlist = {"cell3-left"}});
  HealthReport real;
  real.scans = {Scan(0, "cell3-left", 0.02)};
  r.sensors.Record(real, 100);
  for (int job = 0; job < 50; ++job)
    r.sensors.Record(JobOfSensors("j" + std::to_string(job), 2), 200);
  const auto s = r.Samples();
  EXPECT_DOUBLE_EQ(s.at("scanprep_sensor_noise_mm{sensor=\"cell3-left\"}"), 0.02);
  EXPECT_DOUBLE_EQ(s.at("scanprep_sensor_last_report_timestamp_seconds{sensor=\"cell3-left\"}"),
                   100);
  EXPECT_EQ(CountSeries(s, "scanprep_sensor_noise_mm"), 3);  // cell3-left, j49's two
  EXPECT_DOUBLE_EQ(s.at("scanprep_sensor_labels_evicted_total"), 98);

  Recorder listed_only({.max_sensors = 0, .sensor_allowlist = {"cell3-left"}});
  real.scans.push_back(Scan(1, "intruder", 0.5));
  listed_only.sensors.Record(real, 100);
  const auto t = listed_only.Samples();
  EXPECT_DOUBLE_EQ(t.at("scanprep_sensor_noise_mm{sensor=\"cell3-left\"}"), 0.02);
  EXPECT_DOUBLE_EQ(t.at("scanprep_sensor_noise_mm{sensor=\"other\"}"), 0.5);
  EXPECT_EQ(CountSeries(t, "scanprep_sensor_noise_mm"), 2);
}

// Pair series are bounded by --max_sensor_pairs, not by the scans a job has: the finding's two
// jobs of 64 overlapping scans made 14,760 pair series. A pair's series go with either sensor,
// and a pair of two allow-listed sensors is kept like them.
TEST(SensorMetrics, PairSeriesAreBoundedWhateverTheScansPerJob) {
  Recorder r({.max_sensors = 64, .max_sensor_pairs = 16, .sensor_allowlist = {"L", "R"}});
  HealthReport real = JobOfSensors("x", 2, 1);
  real.scans[0].sensor_id = "L";
  real.scans[1].sensor_id = "R";
  r.sensors.Record(real, 100);
  r.sensors.Record(JobOfSensors("a", 64, 4), 200);  // 246 pairs: 16 labelled, the rest "other"
  auto s = r.Samples();
  const std::string median = "scanprep_sensor_pair_residual_median_mm";
  EXPECT_EQ(CountSeries(s, median), 1 + 16 + 1);  // L|R, 16 of a's, other
  EXPECT_TRUE(s.contains(median + "{sensor_pair=\"a0|a1\"}"));
  EXPECT_TRUE(s.contains(median + "{sensor_pair=\"other\"}"));

  // b's sensors evict a's, and with them a's pairs; b's pairs take the slots.
  r.sensors.Record(JobOfSensors("b", 64, 4), 300);
  s = r.Samples();
  EXPECT_EQ(CountSeries(s, median), 1 + 16 + 1);
  EXPECT_EQ(CountSeries(s, median, "a0|"), 0);
  EXPECT_TRUE(s.contains(median + "{sensor_pair=\"b0|b1\"}"));
  EXPECT_TRUE(s.contains(median + "{sensor_pair=\"L|R\"}"));
  EXPECT_DOUBLE_EQ(s.at("scanprep_sensor_labels_evicted_total"), 64);
  EXPECT_DOUBLE_EQ(s.at("scanprep_sensor_pair_labels_evicted_total"), 16);
}

// The /metrics body under the finding's flood: jobs of the same 64 sensors with the longest ids
// (64 bytes), each job pairing them differently (256 pairs, health's most). Every ordered pair
// got series of its own for the server's lifetime (4,032 at most, 4 gauges each: the finding's
// 1.3 MB); the pairs are held by recency now, and the body stays within the bound
// docs/server.md states.
TEST(SensorMetrics, TheBodyIsBoundedUnderAFloodOfIds) {
  Recorder r;
  for (int job = 0; job < 20; ++job) {
    HealthReport flood = JobOfSensors(std::string(62, 's'), 64);
    for (ScanHealth& scan : flood.scans) {
      scan.sensor_id.resize(64, '_');
      scan.noise_to_uncertainty = scan.outlier_share = 0.5;
    }
    for (uint32_t i = 0; i < 64; ++i) {
      for (uint32_t k = 0; k < 4; ++k) {
        PairHealth pair;
        pair.fixed = i;
        pair.moving = (i + 1 + 3 * job + k) % 64;
        pair.residual_median_mm = pair.residual_spread_mm = -0.001 * k;
        if (pair.moving != i) flood.pairs.push_back(pair);
      }
    }
    r.sensors.Record(flood, 1'700'000'000 + job);
  }
  const auto s = r.Samples();
  const size_t bytes = r.registry.Serialize().size();
  std::printf("sensor series after the flood: %d pairs, %zu bytes\n",
              CountSeries(s, "scanprep_sensor_pair_residual_median_mm"), bytes);
  EXPECT_EQ(CountSeries(s, "scanprep_sensor_noise_mm"), 64);
  EXPECT_LE(CountSeries(s, "scanprep_sensor_pair_residual_median_mm"), 256 + 1);  // and other
  EXPECT_LT(bytes, 300'000u);
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

// The finding through the service: two jobs of twelve squatting sensors each, then the plant's
// cell3-left (allow-listed) and cell3-right. Both get their series, the squatters' stay within
// --max_sensors and --max_sensor_pairs.
TEST(SensorMetrics, TheServersAllowListedSensorIsExportedAfterASquatterFlood) {
  server::ServerOptions options;
  options.metrics_listen = "127.0.0.1:0";
  options.sensor_metrics = {
      .max_sensors = 8, .max_sensor_pairs = 16, .sensor_allowlist = {"cell3-left"}};
  scanprep::testing::InProcessServer server(options);
  const auto send = [&](const std::vector<std::string>& sensors) {
    std::vector<sim::SimSensor> poses;
    for (size_t i = 0; i < sensors.size(); ++i) {
      poses.push_back(sim::TwoOverlappingSensors(sim::Part::kPlane)[i % 2]);
    }
    sim::SimulatedCloud scan = sim::SimulateWithPointCount(
        sim::Part::kPlane, poses, 1'500 * sensors.size(), 0.01, sensors.size());
    for (size_t i = 0; i < sensors.size(); ++i) scan.cloud.scans[i].sensor_id = sensors[i];
    auto args = client::ParseArgs({}, client::JobFlags());
    ASSERT_TRUE(args.ok()) << args.status();
    auto job = client::BuildJobFromCloud(*args, std::move(scan.cloud));
    ASSERT_TRUE(job.ok()) << job.status();
    auto result = server.Client().Process(job->header, job->points);
    ASSERT_TRUE(result.ok()) << result.status();
  };
  for (const char* prefix : {"squatA", "squatB"}) {
    std::vector<std::string> squatters;
    for (int i = 0; i < 12; ++i) squatters.push_back(prefix + std::to_string(i));
    send(squatters);
  }
  send({"cell3-left", "cell3-right"});

  const auto s = scanprep::testing::Scrape(server.server().metrics_port());
  EXPECT_TRUE(s.contains("scanprep_sensor_noise_mm{sensor=\"cell3-left\"}"));
  EXPECT_TRUE(s.contains("scanprep_sensor_noise_mm{sensor=\"cell3-right\"}"));
  EXPECT_TRUE(s.contains(
      "scanprep_sensor_pair_residual_median_mm{sensor_pair=\"cell3-left|cell3-right\"}"));
  EXPECT_LE(CountSeries(s, "scanprep_sensor_noise_mm"), 1 + 8 + 1);  // listed, slots, other
  EXPECT_LE(CountSeries(s, "scanprep_sensor_pair_residual_median_mm"), 16 + 1);
  // Job B's first eight evict job A's labelled eight, cell3-right one of B's; cell3-left none.
  EXPECT_DOUBLE_EQ(s.at("scanprep_sensor_labels_evicted_total"), 9);
}

TEST(SensorMetrics, OptionsAreChecked) {
  EXPECT_TRUE(CheckSensorMetricsOptions({}).ok());
  EXPECT_FALSE(CheckSensorMetricsOptions({.max_sensors = -1}).ok());
  EXPECT_FALSE(CheckSensorMetricsOptions({.max_sensor_pairs = -1}).ok());
  EXPECT_TRUE(CheckSensorMetricsOptions({.sensor_allowlist = {"cell3-left", "a.b:c_d"}}).ok());
  for (const char* id : {"", "other", "cell 3", "a|b"}) {
    EXPECT_FALSE(CheckSensorMetricsOptions({.sensor_allowlist = {id}}).ok()) << id;
  }
  EXPECT_FALSE(CheckSensorMetricsOptions({.sensor_allowlist = {std::string(65, 'z')}}).ok());
  EXPECT_FALSE(CheckSensorMetricsOptions({.tolerance_mm = 0}).ok());
  EXPECT_FALSE(CheckSensorMetricsOptions({.rotation_tolerance_deg = std::nan("")}).ok());
}

}  // namespace
}  // namespace scanprep::server
