// SPDX-License-Identifier: Apache-2.0
// Registration against the simulator's truth: three laser-line sensors over two machined parts,
// misregistered by 5-100 µm and 0.005-0.1°. After the stage every pair's components that health
// calls constrained lie within max(10 %, 1 µm) of the truth (rotations as lengths at the cloud's
// extent); a scan whose pose is right stays; a correction beyond the bound leaves the scan and
// warns; a single scan and scans that do not overlap are left alone.
#include "core/stages/registration.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <vector>

#include <gtest/gtest.h>

#include "core/sim/scan_simulator.h"
#include "core/stages/health.h"
#include "tests/support/misregistration.h"
#include "tests/support/stage_call.h"
#include "tests/support/test_data.h"

namespace scanprep {
namespace {

using sim::Part;
using Vector6d = Eigen::Matrix<double, 6, 1>;

constexpr double kDegree = std::numbers::pi / 180;
constexpr size_t kPoints = 100'000;

struct Registered {
  Registration registration;
  PipelineReport report;
};

Registered Register(PointCloud& cloud, const ParamOverrides& params = {}) {
  Registered out;
  auto report = testing::CallStage(
      cloud, "registration", params,
      [&](testing::StageInputs& in) -> absl::Status {
        SCANPREP_ASSIGN_OR_RETURN(
            out.registration,
            RegisterScans(in.cloud, in.measures, in.neighbourhoods, in.Settings(HealthParams()),
                          in.Settings(RegistrationParams()), in.out));
        return absl::OkStatus();
      },
      {"registration"});
  EXPECT_TRUE(report.ok()) << report.status();
  if (report.ok()) out.report = *std::move(report);
  return out;
}

// The motion the stage applied to a scan, in the frame's absolute coordinates.
Eigen::Isometry3d Applied(const ScanRegistration& r, const Eigen::Vector3d& origin) {
  Eigen::Isometry3d m = Eigen::Isometry3d::Identity();
  if (const double angle = r.rotation_deg.norm() * kDegree; angle > 0) {
    m.linear() = Eigen::AngleAxisd(angle, r.rotation_deg.normalized()).toRotationMatrix();
  }
  m.translation() = r.centre - m.linear() * r.centre + r.translation_mm;
  return Eigen::Translation3d(origin) * m * Eigen::Translation3d(-origin);
}

// `motion` linearised at c: translation there (mm) and rotation vector as a length at `extent`.
Vector6d Components(const Eigen::Isometry3d& motion, const Eigen::Vector3d& c, double extent) {
  const Eigen::AngleAxisd turn(motion.linear());
  Vector6d x;
  x << motion * c - c, turn.axis() * turn.angle() * extent;
  return x;
}

double RmsExtent(const PointCloud& cloud) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < cloud.size(); ++i) mean += cloud.point(i).cast<double>();
  mean /= double(cloud.size());
  double sum = 0;
  for (size_t i = 0; i < cloud.size(); ++i) {
    sum += (cloud.point(i).cast<double>() - mean).squaredNorm();
  }
  return std::sqrt(sum / double(cloud.size()));
}

struct Tally {
  size_t components = 0, within = 0;
  // tz, rx and ry: the top face every pair shares sees them.
  size_t top_face = 0, top_face_within = 0;
  double worst_share = 0;  // the largest |after| / max(10 % |before|, 1 µm)
};

// Every pair health calls constrained, component by component: what is left of the truth after
// registration against max(10 % of it, 1 µm).
void Judge(const sim::SimulatedCloud& sim, const std::vector<Eigen::Isometry3d>& truth,
           const Registration& r, double extent, Tally& tally) {
  const Eigen::Vector3d origin = sim.cloud.origin;
  for (const PairHealth& pair : r.pairs_before) {
    const Eigen::Vector3d c = pair.centre + origin;
    const Eigen::Isometry3d before = truth[pair.moving] * truth[pair.fixed].inverse();
    const Eigen::Isometry3d after =
        (Applied(r.scans[pair.moving], origin) * truth[pair.moving]) *
        (Applied(r.scans[pair.fixed], origin) * truth[pair.fixed]).inverse();
    const Vector6d b = Components(before, c, extent), a = Components(after, c, extent);
    for (int k = 0; k < 6; ++k) {
      if (!pair.constrained[k]) continue;
      const double allowed = std::max(0.1 * std::abs(b[k]), 0.001);
      ++tally.components;
      tally.within += std::abs(a[k]) <= allowed;
      if (k >= 2 && k <= 4) {
        ++tally.top_face;
        tally.top_face_within += std::abs(a[k]) <= allowed;
      }
      tally.worst_share = std::max(tally.worst_share, std::abs(a[k]) / allowed);
      if (std::abs(a[k]) > allowed) {
        std::printf("  scans %u-%u %s: before %.2f um, after %.2f um\n", pair.fixed, pair.moving,
                    kMisalignmentAxes[k], 1000 * b[k], 1000 * a[k]);
      }
    }
  }
}

sim::SimulatedCloud Misregistered(Part part, uint64_t seed, std::vector<Eigen::Isometry3d>& truth) {
  return testing::Misregistered(part, seed, kPoints, truth);
}

// Every component health calls constrained is within, the top face's and the rest (36 of 36 on
// each part, the worst at 0.33 of its allowance). Before matches of two faces were left out
// (kMinNormalCosine), the box's +x/−x pair's rz was called constrained and 2 of 38 were not.
TEST(Registration, ConstrainedComponentsWithinTenPercentOrOneMicrometre) {
  for (Part part : {Part::kBoxWithBore, Part::kSteppedBlock}) {
    Tally tally;
    for (uint64_t seed = 1; seed <= 4; ++seed) {
      SCOPED_TRACE(::testing::Message() << "part " << int(part) << " seed " << seed);
      std::vector<Eigen::Isometry3d> truth;
      sim::SimulatedCloud sim = Misregistered(part, seed, truth);
      const double extent = RmsExtent(sim.cloud);
      const Registered r = Register(sim.cloud);
      ASSERT_EQ(r.registration.scans.size(), 3u);
      Judge(sim, truth, r.registration, extent, tally);
      const double steps = r.report.stages.back().parameters.at("registration.steps");
      std::printf("part %d seed %lu: %.0f steps\n", int(part), seed, steps);
      // The work counter: measured 1-2 steps a job; 7-10, at the cap, while matches of two faces
      // moved the box's rz a micrometre a step.
      EXPECT_LE(steps, 6);
      for (const ScanRegistration& scan : r.registration.scans) {
        EXPECT_FALSE(scan.bound_exceeded) << scan.scan;
        ASSERT_TRUE(scan.residual_before_mm && scan.residual_after_mm);
        EXPECT_LE(*scan.residual_after_mm, *scan.residual_before_mm) << scan.scan;
      }
    }
    std::printf("part %d: %zu of %zu constrained components within max(10 %%, 1 um), worst %.2f\n",
                int(part), tally.within, tally.components, tally.worst_share);
    EXPECT_EQ(tally.top_face, 4u * 3 * 3);
    EXPECT_EQ(tally.top_face_within, tally.top_face);
    EXPECT_EQ(tally.within, tally.components);
  }
}

// The control: without registration the same components are far from within (the test can tell).
TEST(Registration, WithoutItTheComponentsAreNotWithin) {
  std::vector<Eigen::Isometry3d> truth;
  sim::SimulatedCloud sim = Misregistered(Part::kSteppedBlock, 1, truth);
  const double extent = RmsExtent(sim.cloud);
  Registered r = Register(sim.cloud, {{"registration.max_iterations", "1"}});
  for (ScanRegistration& scan : r.registration.scans)
    scan = {.scan = scan.scan};  // nothing applied
  Tally tally;
  Judge(sim, truth, r.registration, extent, tally);
  EXPECT_LT(double(tally.within), 0.5 * double(tally.components));
}

// A right pose moves little: every pair's relative motion applied is within 1 µm at the part's
// extent on every component (measured: at most 0.22 µm). With matches of two faces the box's
// +x/−x pair's rz moved 3.1 µm (its standard error 1 µm).
TEST(Registration, AScanWhosePoseIsRightStaysWhereItIs) {
  for (Part part : {Part::kBoxWithBore, Part::kSteppedBlock}) {
    sim::SimulatedCloud sim =
        sim::SimulateWithPointCount(part, sim::ThreeOverlappingSensors(part), kPoints, 0, 3);
    const double extent = RmsExtent(sim.cloud);
    const Registered r = Register(sim.cloud);
    const Eigen::Vector3d origin = sim.cloud.origin;
    for (const PairHealth& pair : r.registration.pairs_before) {
      const Eigen::Vector3d c = pair.centre + origin;
      const Eigen::Isometry3d applied = Applied(r.registration.scans[pair.moving], origin) *
                                        Applied(r.registration.scans[pair.fixed], origin).inverse();
      const Vector6d a = Components(applied, c, extent);
      for (int k = 0; k < 6; ++k) {
        EXPECT_LE(std::abs(a[k]), 0.001) << "part " << int(part) << " scans " << pair.fixed << "-"
                                         << pair.moving << " " << kMisalignmentAxes[k];
      }
    }
  }
}

// A pose 80 µm off needs more than a tenth of a spacing: left as it was, warned; the control with
// a bound of 20 spacings moves it.
TEST(Registration, ACorrectionBeyondTheBoundLeavesTheScanAndWarns) {
  for (const char* bound : {"0.1", "20"}) {
    std::vector<sim::SimSensor> sensors = sim::ThreeOverlappingSensors(Part::kSteppedBlock);
    sensors[1].misregistration = Eigen::Translation3d(0, 0, 0.08) * Eigen::Isometry3d::Identity();
    sim::SimulatedCloud sim =
        sim::SimulateWithPointCount(Part::kSteppedBlock, sensors, kPoints, 0, 5);
    const std::vector<float> z = sim.cloud.z;
    const Registered r = Register(sim.cloud, {{"registration.max_correction", bound}});
    const bool tight = std::string(bound) == "0.1";
    size_t warned = 0;
    for (const Warning& w : r.report.warnings)
      warned += w.code == WarningCode::kRegistrationBoundExceeded;
    size_t exceeded = 0;
    for (const ScanRegistration& scan : r.registration.scans) exceeded += scan.bound_exceeded;
    EXPECT_EQ(exceeded > 0, tight) << bound;
    EXPECT_EQ(warned > 0, tight) << bound;
    size_t moved = 0;
    for (size_t i = 0; i < z.size(); ++i) {
      const uint32_t s = sim.cloud.scan[i];
      if (r.registration.scans[s].bound_exceeded) {
        // Put back by the inverse motion: within float's rounding of where it was.
        ASSERT_NEAR(sim.cloud.z[i], z[i], 4e-7 * std::max(1.f, std::abs(z[i]))) << "point " << i;
      }
      moved += sim.cloud.z[i] != z[i];
    }
    if (!tight) EXPECT_GT(moved, z.size() / 4);
  }
}

TEST(Registration, ASingleScanIsLeftAlone) {
  sim::SimulatedCloud sim = sim::SimulateWithPointCount(
      Part::kBoxWithBore, sim::FrontalSensor(Part::kBoxWithBore), 20'000, 0, 1);
  const std::vector<float> x = sim.cloud.x;
  const Registered r = Register(sim.cloud);
  EXPECT_TRUE(r.registration.scans.empty());
  EXPECT_EQ(sim.cloud.x, x);
}

// Two scans 1 m apart: no pair, no motion, no warning.
TEST(Registration, ScansThatDoNotOverlapStay) {
  sim::SimulatedCloud sim = sim::SimulateWithPointCount(
      Part::kBoxWithBore, sim::ThreeOverlappingSensors(Part::kBoxWithBore), 30'000, 0, 2);
  for (size_t i = 0; i < sim.cloud.size(); ++i) sim.cloud.x[i] += 1000.f * float(sim.cloud.scan[i]);
  const std::vector<float> x = sim.cloud.x;
  const Registered r = Register(sim.cloud);
  EXPECT_TRUE(r.registration.pairs_before.empty());
  EXPECT_TRUE(r.registration.scans.empty());  // none overlaps another: none to report
  EXPECT_EQ(sim.cloud.x, x);
  EXPECT_TRUE(
      r.report.warnings.empty() ||
      std::none_of(r.report.warnings.begin(), r.report.warnings.end(), [](const Warning& w) {
        return w.code == WarningCode::kRegistrationBoundExceeded;
      }));
}

// The real scans with their .conf poses are not made worse: the residual of every scan that moved
// against the others does not grow (measured: the bunny pair 1 %). The Happy Buddha's .conf
// poses are off by more than its noise: Open3D's point-to-plane ICP, pair by pair, cuts the
// pairs' spread by 30-57 % (docs/health.md, Real scans), and the stage cuts every scan's residual
// by more than a third (measured 43-53 %).
TEST(Registration, RealScansAreNotMadeWorse) {
  SCANPREP_REQUIRE_SHARED_DATA(data);
  struct Job {
    const char* dir;
    const char* conf;
    std::vector<std::string> scans;
    double scanline_spacing_mm;
    double least_cut;  // the share of every scan's residual registration removes, at least
  };
  const std::vector<Job> jobs = {
      {"stanford_bunny_range_scans", "bun.conf", {"bun000", "bun045"}, 0.82, 0},
      {"stanford_happy_stand_range_scans",
       "happyStandRight.conf",
       {"happyStandRight_24", "happyStandRight_264", "happyStandRight_288", "happyStandRight_312",
        "happyStandRight_336"},
       0.38,
       1.0 / 3},
  };
  for (const Job& job : jobs) {
    PointCloud cloud =
        testing::LoadRangeScansMm(data / job.dir, job.conf, job.scans, job.scanline_spacing_mm);
    ASSERT_EQ(cloud.scans.size(), job.scans.size());
    const Registered r = Register(cloud);
    for (const ScanRegistration& scan : r.registration.scans) {
      SCOPED_TRACE(::testing::Message() << job.dir << " scan " << scan.scan);
      std::printf("%s scan %u: residual %.4f -> %.4f mm, %d steps, %d components%s\n", job.dir,
                  scan.scan, *scan.residual_before_mm, *scan.residual_after_mm, scan.iterations,
                  scan.constrained_directions, scan.bound_exceeded ? ", put back" : "");
      // A scan put back is judged by the others, which moved toward each other and away from it.
      if (scan.bound_exceeded) continue;
      EXPECT_LE(*scan.residual_after_mm, (1 - job.least_cut) * *scan.residual_before_mm);
    }
  }
}

}  // namespace
}  // namespace scanprep
