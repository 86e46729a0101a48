// SPDX-License-Identifier: Apache-2.0
// Per-sensor health metrics (issue 32): every job's HealthReport, exported under the `sensor`
// and `sensor_pair` labels so a drifting calibration or a dirty lens shows up as a trend and an
// alert (deploy/prometheus/alerts.yml: ScanprepSensor*). Cardinality is bounded, and no client
// can keep the plant's sensors out of their labels (issue 39 finding 6): the operator's
// allow-listed sensors always have their own label; up to `max_sensors` others hold one by
// recency, a new sensor taking the least recently reported one's (whose series go); up to
// `max_sensor_pairs` pairs likewise. What finds no label shares "other".
#pragma once

#include <cstdint>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "core/stages/health_report.h"
#include "server/metrics/label_slots.h"
#include "server/metrics/registry.h"

namespace scanprep::server {

struct SensorMetricsOptions {
  // Sensors besides the allow-list's that hold a `sensor` label value at once, by recency; 0:
  // only the allow-listed sensors have labels, every other one is "other".
  int max_sensors = 64;
  // Pairs that hold a `sensor_pair` label value at once, by recency, besides the pairs of two
  // allow-listed sensors (whatever a job's scan count: health keeps up to 256 pairs a job).
  int max_sensor_pairs = 256;
  // Sensor ids that always have their own label, never evicted (--sensor_allowlist).
  std::vector<std::string> sensor_allowlist;
  // What a pair's |residual median| and |translation| (mm) and |rotation| (degrees) may reach
  // before ScanprepSensorPairMisaligned fires; exported as gauges the rule compares against.
  double tolerance_mm = 0.05;
  double rotation_tolerance_deg = 0.05;
};

// OK unless max_sensors or max_sensor_pairs is negative, an allow-listed id is not a valid
// sensor id (or is "other"), or a tolerance is not positive; the message names the flag.
absl::Status CheckSensorMetricsOptions(const SensorMetricsOptions& options);

// The label value every sensor without a label of its own shares (and every pair with such a
// sensor, or without a label of its own).
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
  // kFoldedSensor when it is not allow-listed and every slot is held by this job's sensors.
  // Called under mu_, like the rest.
  std::string Label(const std::string& sensor_id);
  // "fixed|moving", or kFoldedSensor for a pair with a folded sensor or without a slot.
  std::string PairLabel(const std::string& fixed, const std::string& moving);
  // Removes an evicted sensor's series, and its pairs'.
  void Evict(const std::string& sensor);
  void EvictPair(const std::string& pair);

  std::mutex mu_;
  const std::set<std::string> allowed_;
  metrics::LabelSlots sensor_slots_, pair_slots_;
  uint64_t job_ = 0;  // the round of the label slots

  metrics::Family<metrics::Gauge>& noise_;
  metrics::Family<metrics::Gauge>& noise_ratio_;
  metrics::Family<metrics::Gauge>& outlier_share_;
  metrics::Family<metrics::Gauge>& last_report_;
  metrics::Family<metrics::Counter>& scans_;
  metrics::Counter& folded_;
  metrics::Counter& evicted_;
  metrics::Counter& pairs_evicted_;
  metrics::Family<metrics::Gauge>& residual_median_;
  metrics::Family<metrics::Gauge>& residual_spread_;
  metrics::Family<metrics::Gauge>& translation_;
  metrics::Family<metrics::Gauge>& rotation_;
  metrics::Family<metrics::Gauge>& translation_se_;
  metrics::Family<metrics::Gauge>& rotation_se_;
};

}  // namespace scanprep::server
