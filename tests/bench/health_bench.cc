// SPDX-License-Identifier: Apache-2.0
// The health stage's accuracy as markdown tables (not a timing benchmark): the simulated box with
// bore seen by two overlapping sensors, the second misregistered by each shift and rotation of
// issue 32's grid, then its noise scaled; truth beside what the stage reports. Truth is the
// misregistration expressed at the reported centre c: translation R·c + t − c, rotation vector.
//
//   health_bench [points = 1000000] [seed = 20261126]
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <numbers>
#include <string>
#include <vector>

#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "core/pipeline/pipeline.h"
#include "core/sim/scan_simulator.h"

namespace scanprep::bench {
namespace {

// A seed no test uses: the table is measured on clouds the suite was not tuned on.
constexpr uint64_t kSeed = 20261126;
constexpr double kDegree = std::numbers::pi / 180;

sim::SimulatedCloud TwoScans(const Eigen::Isometry3d& misregistration, double noise_scale,
                             size_t points) {
  std::vector<sim::SimSensor> sensors = sim::TwoOverlappingSensors(sim::Part::kBoxWithBore);
  sensors[1].misregistration = misregistration;
  sensors[1].noise_sigma *= noise_scale;
  return sim::SimulateWithPointCount(sim::Part::kBoxWithBore, sensors, points, 0, kSeed);
}

HealthReport Health(PointCloud& cloud) {
  CancelToken cancel;
  absl::StatusOr<PipelineReport> report = RunPipeline(cloud, {.stages = {"health"}}, cancel);
  if (!report.ok() || !report->health) {
    std::fprintf(stderr, "health_bench: %s\n", report.status().ToString().c_str());
    std::exit(1);
  }
  return *report->health;
}

// "a / b / c" in µm (translations) or millidegrees (rotations); "–" for a flagged component.
std::string Triple(const Eigen::Vector3d& v, double unit, const bool* constrained) {
  std::vector<std::string> parts;
  for (int k = 0; k < 3; ++k) {
    parts.push_back(constrained && !constrained[k] ? "–" : absl::StrFormat("%.2f", v[k] / unit));
  }
  return absl::StrJoin(parts, " / ");
}

void MisalignmentRow(const std::string& name, const Eigen::Isometry3d& motion, size_t points) {
  sim::SimulatedCloud sim = TwoScans(motion, 1.0, points);
  const HealthReport health = Health(sim.cloud);
  if (health.pairs.size() != 1) {
    std::printf("| %s | %zu pairs | | | | |\n", name.c_str(), health.pairs.size());
    return;
  }
  const PairHealth& pair = health.pairs[0];
  const Eigen::Vector3d c = pair.centre + sim.cloud.origin;
  const Eigen::AngleAxisd aa(motion.linear());
  const Eigen::Vector3d t = motion * c - c, w = aa.axis() * aa.angle() / kDegree;
  std::printf("| %s | %s | %s | %s | %s | %zu |\n", name.c_str(), Triple(t, 1e-3, nullptr).c_str(),
              Triple(pair.translation_mm, 1e-3, &pair.constrained[0]).c_str(),
              Triple(w, 1e-3, nullptr).c_str(),
              Triple(pair.rotation_deg, 1e-3, &pair.constrained[3]).c_str(),
              static_cast<size_t>(pair.overlap_points));
  std::fflush(stdout);
}

}  // namespace
}  // namespace scanprep::bench

int main(int argc, char** argv) {
  using namespace scanprep::bench;
  const size_t points = argc > 1 ? std::strtoull(argv[1], nullptr, 10) : 1'000'000;
  std::printf(
      "Box with bore, two sensors (TwoOverlappingSensors), %zu points, seed %llu; the\n"
      "second sensor (the pair's moving scan) misregistered about the frame origin.\n\n",
      points, static_cast<unsigned long long>(kSeed));
  std::printf(
      "| misregistration | truth t at c (µm) | estimate t (µm) | truth ω (m°) | estimate ω (m°) "
      "| overlap points |\n|---|---|---|---|---|---|\n");
  MisalignmentRow("none", Eigen::Isometry3d::Identity(), points);
  const char* axes = "xyz";
  for (int axis = 0; axis < 3; ++axis) {
    for (double microns : {2.0, 5.0, 10.0, 20.0}) {
      Eigen::Isometry3d m = Eigen::Isometry3d::Identity();
      m.translation() = Eigen::Vector3d::Unit(axis) * microns * 1e-3;
      MisalignmentRow(absl::StrFormat("%g µm along %c", microns, axes[axis]), m, points);
    }
  }
  for (int axis = 0; axis < 3; ++axis) {
    for (double degrees : {0.005, 0.02, 0.05}) {
      const Eigen::Isometry3d m(Eigen::AngleAxisd(degrees * kDegree, Eigen::Vector3d::Unit(axis)));
      MisalignmentRow(absl::StrFormat("%g° about %c", degrees, axes[axis]), m, points);
    }
  }
  // Far above the noise, as on a badly calibrated cell (docs/health.md's real scans).
  Eigen::Isometry3d large(Eigen::AngleAxisd(0.3 * kDegree, Eigen::Vector3d(1, 1, 0).normalized()));
  large.translation() = Eigen::Vector3d(0.1, 0.1, 0.1);
  MisalignmentRow("100 µm along x, y, z and 0.3° about (1, 1, 0)", large, points);
  std::printf(
      "\n| noise of sensor 2 | σ̂ sensor 1 (µm) | σ̂ sensor 2 (µm) | ratio to 1.0× |\n"
      "|---|---|---|---|\n");
  double first = 0;
  for (double scale : {1.0, 1.5, 2.0}) {
    scanprep::sim::SimulatedCloud sim = TwoScans(Eigen::Isometry3d::Identity(), scale, points);
    const scanprep::HealthReport health = Health(sim.cloud);
    const double a = health.scans[0].noise_mm.value_or(0), b = health.scans[1].noise_mm.value_or(0);
    if (first == 0) first = b;
    std::printf("| %.1f× | %.2f | %.2f | %.3f |\n", scale, 1e3 * a, 1e3 * b, b / first);
    std::fflush(stdout);
  }
  return 0;
}
