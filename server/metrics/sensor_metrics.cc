// SPDX-License-Identifier: Apache-2.0
#include "server/metrics/sensor_metrics.h"

#include <algorithm>
#include <array>
#include <map>
#include <optional>
#include <vector>

#include "absl/strings/str_cat.h"
#include "wire/convert.h"

namespace scanprep::server {
namespace {

// Per label value, the mean of one job's values of each of N gauges (absent values skipped).
template <size_t N>
class JobMeans {
 public:
  void Add(const std::string& label, const std::array<std::optional<double>, N>& values) {
    Sums& sums = by_label_[label];
    for (size_t k = 0; k < N; ++k) {
      if (!values[k]) continue;
      sums[k].first += *values[k];
      ++sums[k].second;
    }
  }
  void SetGauges(const std::array<metrics::Family<metrics::Gauge>*, N>& gauges) const {
    for (const auto& [label, sums] : by_label_) {
      for (size_t k = 0; k < N; ++k) {
        if (sums[k].second > 0) gauges[k]->WithLabels({label}).Set(sums[k].first / sums[k].second);
      }
    }
  }
  const std::map<std::string, std::array<std::pair<double, int>, N>>& labels() const {
    return by_label_;
  }

 private:
  using Sums = std::array<std::pair<double, int>, N>;
  std::map<std::string, Sums> by_label_;
};

// The largest of `errors` over the pair's constrained components (`first` the index of errors.x
// in kMisalignmentAxes); none when no component is constrained.
std::optional<double> LargestConstrained(const PairHealth& pair, const Eigen::Vector3d& errors,
                                         size_t first) {
  std::optional<double> largest;
  for (size_t k = 0; k < 3; ++k) {
    if (pair.constrained[first + k]) largest = std::max(largest.value_or(0), errors[k]);
  }
  return largest;
}

}  // namespace

absl::Status CheckSensorMetricsOptions(const SensorMetricsOptions& options) {
  if (options.max_sensors < 0 || options.max_sensor_pairs < 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("--max_sensors and --max_sensor_pairs must be 0 or more, got ",
                     options.max_sensors, " and ", options.max_sensor_pairs));
  }
  for (const std::string& id : options.sensor_allowlist) {
    const bool valid = !id.empty() && id.size() <= kMaxSensorIdBytes &&
                       std::all_of(id.begin(), id.end(), IsSensorIdChar) && id != kFoldedSensor;
    if (!valid) {
      return absl::InvalidArgumentError(absl::StrCat(
          "--sensor_allowlist: \"", id, "\" is not a sensor id (1 to ", kMaxSensorIdBytes,
          " bytes of [A-Za-z0-9._:-], not \"", kFoldedSensor, "\")"));
    }
  }
  // !(x > 0) also refuses NaN.
  if (!(options.tolerance_mm > 0) || !(options.rotation_tolerance_deg > 0)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--sensor_tolerance_mm and --sensor_rotation_tolerance_deg must be positive, got ",
        options.tolerance_mm, " and ", options.rotation_tolerance_deg));
  }
  return absl::OkStatus();
}

SensorMetrics::SensorMetrics(metrics::Registry& r, const SensorMetricsOptions& options)
    : allowed_(options.sensor_allowlist.begin(), options.sensor_allowlist.end()),
      sensor_slots_(options.max_sensors),
      pair_slots_(options.max_sensor_pairs),
      noise_(r.AddGauge("scanprep_sensor_noise_mm",
                        "Measured noise sigma-hat of the sensor's scans in its last job (median "
                        "RMS residual of the normal fits, mm; mean over the job's scans).",
                        {"sensor"})),
      noise_ratio_(r.AddGauge("scanprep_sensor_noise_to_uncertainty_ratio",
                              "The sensor's noise sigma-hat over its stated uncertainty u, last "
                              "job (only scans that stated u).",
                              {"sensor"})),
      outlier_share_(r.AddGauge("scanprep_sensor_outlier_ratio",
                                "Share of the sensor's points removed as outliers, last job.",
                                {"sensor"})),
      last_report_(r.AddGauge("scanprep_sensor_last_report_timestamp_seconds",
                              "Unix time of the sensor's last job with a health report.",
                              {"sensor"})),
      scans_(r.AddCounter("scanprep_sensor_scans_total",
                          "Scans of the sensor whose health was reported.", {"sensor"})),
      folded_(r.AddCounter("scanprep_sensor_labels_folded_total",
                           "Scan health reports exported under sensor=\"other\": the sensor "
                           "is not allow-listed and the job's other sensors held every one of "
                           "the --max_sensors labels.")
                  .WithLabels({})),
      evicted_(r.AddCounter("scanprep_sensor_labels_evicted_total",
                            "Sensors whose label (and series) went to a newer sensor: the least "
                            "recently reported of --max_sensors.")
                   .WithLabels({})),
      pairs_evicted_(r.AddCounter("scanprep_sensor_pair_labels_evicted_total",
                                  "Sensor pairs whose label (and series) went to a newer pair (the "
                                  "least recently reported of --max_sensor_pairs) or with an "
                                  "evicted sensor.")
                         .WithLabels({})),
      residual_median_(
          r.AddGauge("scanprep_sensor_pair_residual_median_mm",
                     "Median signed point-to-plane distance of the moving sensor's "
                     "scan to the fixed one's surface in their overlap, last job (mm).",
                     {"sensor_pair"})),
      residual_spread_(r.AddGauge("scanprep_sensor_pair_residual_spread_mm",
                                  "Robust spread (1.4826 MAD) of that distance, last job (mm).",
                                  {"sensor_pair"})),
      translation_(r.AddGauge("scanprep_sensor_pair_translation_mm",
                              "Length of the estimated rigid misalignment's translation between "
                              "the pair's scans, last job (mm; unconstrained components as 0).",
                              {"sensor_pair"})),
      rotation_(r.AddGauge("scanprep_sensor_pair_rotation_degrees",
                           "Angle of the estimated rigid misalignment's rotation between the "
                           "pair's scans, last job (degrees; unconstrained components as 0).",
                           {"sensor_pair"})),
      translation_se_(
          r.AddGauge("scanprep_sensor_pair_translation_standard_error_mm",
                     "Largest standard error of the misalignment's constrained translation "
                     "components, last job (mm; absent when none is constrained).",
                     {"sensor_pair"})),
      rotation_se_(r.AddGauge("scanprep_sensor_pair_rotation_standard_error_degrees",
                              "Largest standard error of the misalignment's constrained rotation "
                              "components, last job (degrees; absent when none is constrained).",
                              {"sensor_pair"})) {
  r.AddGauge("scanprep_sensor_tolerance_mm",
             "What a sensor pair's |residual median| and misalignment translation may reach "
             "(--sensor_tolerance_mm).")
      .WithLabels({})
      .Set(options.tolerance_mm);
  r.AddGauge("scanprep_sensor_rotation_tolerance_degrees",
             "What a sensor pair's misalignment rotation may reach "
             "(--sensor_rotation_tolerance_deg).")
      .WithLabels({})
      .Set(options.rotation_tolerance_deg);
}

std::string SensorMetrics::Label(const std::string& sensor_id) {
  std::string label = sensor_id.substr(0, kMaxSensorIdBytes);
  for (char& c : label) {
    if (!IsSensorIdChar(c)) c = '_';
  }
  if (label == kFoldedSensor || allowed_.contains(label)) return label;
  const metrics::LabelSlots::Use use = sensor_slots_.Take(label, job_);
  if (!use.held) return kFoldedSensor;
  if (use.evicted) Evict(*use.evicted);
  return label;
}

std::string SensorMetrics::PairLabel(const std::string& fixed, const std::string& moving) {
  if (fixed == kFoldedSensor || moving == kFoldedSensor) return kFoldedSensor;
  const std::string label = fixed + "|" + moving;
  if (allowed_.contains(fixed) && allowed_.contains(moving)) return label;
  const metrics::LabelSlots::Use use = pair_slots_.Take(label, job_);
  if (!use.held) return kFoldedSensor;
  if (use.evicted) EvictPair(*use.evicted);
  return label;
}

void SensorMetrics::Evict(const std::string& sensor) {
  evicted_.Inc();
  for (auto* family : {&noise_, &noise_ratio_, &outlier_share_, &last_report_}) {
    family->Remove({sensor});
  }
  scans_.Remove({sensor});
  // '|' is not a sensor id character: the pair labels naming the sensor are exactly these.
  const std::string as_fixed = sensor + "|", as_moving = "|" + sensor;
  const std::vector<std::string> pairs = pair_slots_.ReleaseIf([&](const std::string& pair) {
    return pair.starts_with(as_fixed) || pair.ends_with(as_moving);
  });
  for (const std::string& pair : pairs) EvictPair(pair);
}

void SensorMetrics::EvictPair(const std::string& pair) {
  pairs_evicted_.Inc();
  for (auto* family : {&residual_median_, &residual_spread_, &translation_, &rotation_,
                       &translation_se_, &rotation_se_}) {
    family->Remove({pair});
  }
}

void SensorMetrics::Record(const HealthReport& health, double unix_seconds) {
  std::lock_guard lock(mu_);
  ++job_;
  std::vector<std::string> label_of_scan(health.scans.size());
  JobMeans<3> sensors;
  for (size_t i = 0; i < health.scans.size(); ++i) {
    const ScanHealth& scan = health.scans[i];
    if (scan.sensor_id.empty()) continue;
    label_of_scan[i] = Label(scan.sensor_id);
    if (label_of_scan[i] == kFoldedSensor) folded_.Inc();
    scans_.WithLabels({label_of_scan[i]}).Inc();
    sensors.Add(label_of_scan[i], {scan.noise_mm, scan.noise_to_uncertainty, scan.outlier_share});
  }
  sensors.SetGauges({&noise_, &noise_ratio_, &outlier_share_});
  for (const auto& [label, sums] : sensors.labels()) {
    last_report_.WithLabels({label}).Set(unix_seconds);
  }

  JobMeans<6> pairs;
  for (const PairHealth& pair : health.pairs) {
    if (pair.fixed >= label_of_scan.size() || pair.moving >= label_of_scan.size()) continue;
    const std::string& fixed = label_of_scan[pair.fixed];
    const std::string& moving = label_of_scan[pair.moving];
    if (fixed.empty() || moving.empty()) continue;
    const std::string label = PairLabel(fixed, moving);
    pairs.Add(label, {pair.residual_median_mm, pair.residual_spread_mm, pair.translation_mm.norm(),
                      pair.rotation_deg.norm(), LargestConstrained(pair, pair.translation_se_mm, 0),
                      LargestConstrained(pair, pair.rotation_se_deg, 3)});
  }
  pairs.SetGauges({&residual_median_, &residual_spread_, &translation_, &rotation_,
                   &translation_se_, &rotation_se_});
}

}  // namespace scanprep::server
