// SPDX-License-Identifier: Apache-2.0
// Per-sensor health metrics (issue 32): every job's HealthReport, exported under the `sensor`
// and `sensor_pair` labels so a drifting calibration or a dirty lens shows up as a trend and an
// alert (deploy/prometheus/alerts.yml: ScanprepSensor*). Cardinality is bounded: the first
// `max_sensors` distinct sensor ids get label values of their own, later ones share "other".
#pragma once

#include <cstdint>
#include <mutex>
#include <set>
#include <string>

#include "absl/status/status.h"
#include "core/stages/health_report.h"
#include "server/metrics/registry.h"

namespace scanprep::server {

struct SensorMetricsOptions {
  int max_sensors = 64;  // distinct `sensor` label values; later sensors fold into "other"
  // What a pair's |residual median| and |translation| (mm) and |rotation| (degrees) may reach
  // before ScanprepSensorPairMisaligned fires; exported as gauges the rule compares against.
  double tolerance_mm = 0.05;
  double rotation_tolerance_deg = 0.05;
};

// OK unless max_sensors is negative or a tolerance is not positive; the message names the flag.
absl::Status CheckSensorMetricsOptions(const SensorMetricsOptions& options);

// The label value every sensor beyond max_sensors shares (and a pair with such a sensor).
inline constexpr char kFoldedSensor[] = "other";

class SensorMetrics {
 public:
  SensorMetrics(metrics::Registry& registry, const SensorMetricsOptions& options);

  // One job's health, reported at `unix_seconds`. Scans without a sensor id, and pairs without
  // both, are not exported. Several scans of one sensor (or pairs of one sensor pair) in a job
  // set the gauges to their mean.
  void Record(const HealthReport& health, double unix_seconds);

 private:
  // The sensor's label value: its id (sanitised again, though convert checked it), or
  // kFoldedSensor once max_sensors others have one. Called under mu_.
  std::string Label(const std::string& sensor_id);

  const int max_sensors_;
  std::mutex mu_;
  std::set<std::string> labelled_;  // at most max_sensors_

  metrics::Family<metrics::Gauge>& noise_;
  metrics::Family<metrics::Gauge>& noise_ratio_;
  metrics::Family<metrics::Gauge>& outlier_share_;
  metrics::Family<metrics::Gauge>& last_report_;
  metrics::Family<metrics::Counter>& scans_;
  metrics::Counter& folded_;
  metrics::Family<metrics::Gauge>& residual_median_;
  metrics::Family<metrics::Gauge>& residual_spread_;
  metrics::Family<metrics::Gauge>& translation_;
  metrics::Family<metrics::Gauge>& rotation_;
};

}  // namespace scanprep::server
