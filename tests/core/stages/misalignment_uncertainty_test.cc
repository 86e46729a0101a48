// SPDX-License-Identifier: Apache-2.0
// The misalignment's standard errors against the simulator's truth over 20 seeds and two part
// geometries: three laser-line sensors (from +x, −x and −y), the second and third misregistered by
// a random rigid motion of up to 20 µm and 0.02°. A component the stage calls constrained must lie
// within two of its standard errors of the truth in at least 95 % of the cases (the issue's
// promise); the ones it flags are those its overlap sees too weakly for that (the +x/−x pair's ty,
// which the least-squares covariance alone states at 0.1 µm and which reads 3-6 of its jackknife
// errors off).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "core/sim/scan_simulator.h"
#include "core/stages/health.h"
#include "tests/support/stage_call.h"

namespace scanprep {
namespace {

using sim::Part;

constexpr double kDegree = std::numbers::pi / 180;
constexpr size_t kPoints = 100'000;
constexpr uint64_t kSeeds = 20;

Eigen::Isometry3d RandomMotion(std::mt19937& random, double max_shift_mm, double max_deg) {
  std::uniform_real_distribution<double> unit(-1, 1);
  const Eigen::Vector3d axis(unit(random), unit(random), unit(random));
  Eigen::Isometry3d m(Eigen::AngleAxisd(max_deg * unit(random) * kDegree, axis.normalized()));
  m.translation() = Eigen::Vector3d(unit(random), unit(random), unit(random)) * max_shift_mm;
  return m;
}

HealthReport Health(PointCloud& cloud) {
  HealthReport health;
  auto report = testing::CallStage(
      cloud, "health", {},
      [&](testing::StageInputs& in) -> absl::Status {
        SCANPREP_ASSIGN_OR_RETURN(health, MeasureHealth(in.cloud, in.measures, in.neighbourhoods,
                                                        in.Settings(HealthParams()), {}, in.out));
        return absl::OkStatus();
      },
      {"health"});
  EXPECT_TRUE(report.ok()) << report.status();
  return health;
}

struct Coverage {
  size_t constrained = 0, within_two_errors = 0, pairs = 0;
  // Per component (kMisalignmentAxes order): constrained, within ±2σ, the standard errors.
  std::array<size_t, 6> axis_constrained{}, axis_within{};
  std::array<std::vector<double>, 6> errors;
};

double Median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

// One line per component (docs/health.md's seed sweep table): how often constrained, how often
// within ±2σ then, the median standard error (µm; 0.001°).
void Print(const Coverage& c) {
  for (int k = 0; k < 6; ++k) {
    std::printf("  %s constrained %zu of %zu, within 2 se %zu, median se %.2f %s\n",
                kMisalignmentAxes[k], c.axis_constrained[k], c.pairs, c.axis_within[k],
                1000 * Median(c.errors[k]), k < 3 ? "um" : "mdeg");
  }
}

// Every pair's six components against the truth: the relative motion of its two sensors'
// misregistrations, linearised at the reported centre as the stage reports it.
void Count(const sim::SimulatedCloud& sim, const std::vector<Eigen::Isometry3d>& motion,
           const HealthReport& health, Coverage& coverage) {
  for (const PairHealth& pair : health.pairs) {
    ++coverage.pairs;
    const Eigen::Isometry3d relative = motion[pair.moving] * motion[pair.fixed].inverse();
    const Eigen::Vector3d c = pair.centre + sim.cloud.origin;
    const Eigen::AngleAxisd turn(relative.linear());
    Eigen::Matrix<double, 6, 1> truth, estimate, error;
    truth << relative * c - c, turn.axis() * turn.angle() / kDegree;
    estimate << pair.translation_mm, pair.rotation_deg;
    error << pair.translation_se_mm, pair.rotation_se_deg;
    for (int k = 0; k < 6; ++k) {
      if (!pair.constrained[k]) continue;
      ++coverage.constrained;
      const bool within = std::abs(estimate[k] - truth[k]) <= 2 * error[k];
      coverage.within_two_errors += within;
      ++coverage.axis_constrained[k];
      coverage.axis_within[k] += within;
      coverage.errors[k].push_back(error[k]);
      if (!within) {
        std::printf("  outside ±2σ: scans %u-%u %s truth %.5f estimate %.5f ± %.5f\n", pair.fixed,
                    pair.moving, kMisalignmentAxes[k], truth[k], estimate[k], error[k]);
      }
    }
  }
}

TEST(MisalignmentUncertainty,
     TwoStandardErrorsCoverTheTruthOfNineteenConstrainedComponentsInTwenty) {
  Coverage all;
  for (Part part : {Part::kBoxWithBore, Part::kSteppedBlock}) {
    SCOPED_TRACE(::testing::Message() << "part " << static_cast<int>(part));
    Coverage coverage;
    for (uint64_t seed = 1; seed <= kSeeds; ++seed) {
      std::mt19937 random(static_cast<unsigned>(seed));
      std::vector<sim::SimSensor> sensors = sim::ThreeOverlappingSensors(part);
      std::vector<Eigen::Isometry3d> motion(sensors.size(), Eigen::Isometry3d::Identity());
      for (size_t s = 1; s < sensors.size(); ++s) {
        motion[s] = RandomMotion(random, 0.02, 0.02);
        sensors[s].misregistration = motion[s];
      }
      sim::SimulatedCloud sim = sim::SimulateWithPointCount(part, sensors, kPoints, 0, seed);
      Count(sim, motion, Health(sim.cloud), coverage);
    }
    Print(coverage);
    ASSERT_EQ(coverage.pairs, 3 * kSeeds);
    // tz, rx and ry of every pair are seen by the whole top face: a rule that flags them is as
    // wrong as one that states them too well.
    EXPECT_GE(coverage.constrained, 3 * coverage.pairs);
    // Each part on its own (97 % and 95 % here): no geometry far below the promise.
    EXPECT_GE(double(coverage.within_two_errors), 0.9 * double(coverage.constrained))
        << coverage.within_two_errors << " of " << coverage.constrained;
    all.constrained += coverage.constrained;
    all.within_two_errors += coverage.within_two_errors;
  }
  EXPECT_GE(double(all.within_two_errors), 0.95 * double(all.constrained))
      << all.within_two_errors << " of " << all.constrained;
}

}  // namespace
}  // namespace scanprep
