// SPDX-License-Identifier: Apache-2.0
// The health stage against the simulator's ground truth: a sensor misregistered by a known rigid
// motion must be reported with that motion (expressed at the reported centre), a flat overlap
// must flag the in-plane components instead of guessing them, and a sensor's noise σ̂ must follow
// its true noise.
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <string>
#include <tuple>
#include <vector>

#include <gtest/gtest.h>

#include "absl/strings/str_cat.h"
#include "core/pipeline/pipeline.h"
#include "core/sim/scan_simulator.h"
#include "core/stages/health.h"
#include "tests/support/stage_call.h"

namespace scanprep {
namespace {

using sim::Part;

constexpr size_t kPoints = 200'000;
constexpr double kDegree = std::numbers::pi / 180;

// Two overlapping sensors of `part`; the second (scan 1, the pair's moving scan) is misregistered
// by `misregistration` and has its noise scaled by `noise_scale`.
sim::SimulatedCloud TwoScans(Part part, const Eigen::Isometry3d& misregistration,
                             double noise_scale = 1) {
  std::vector<sim::SimSensor> sensors = sim::TwoOverlappingSensors(part);
  sensors[1].misregistration = misregistration;
  sensors[1].noise_sigma *= noise_scale;
  return sim::SimulateWithPointCount(part, sensors, kPoints, 0, 7);
}

// The health function, called after `stages` (which end with "health") have run; outliers and
// correction count as run when listed.
HealthReport Health(PointCloud& cloud, std::vector<std::string> stages = {"health"},
                    const ParamOverrides& params = {}) {
  const auto listed = [&](std::string_view name) {
    return std::find(stages.begin(), stages.end(), name) != stages.end();
  };
  const RemovalStagesRun ran{.outliers = listed("outliers"), .correction = listed("correction")};
  HealthReport health;
  auto report = testing::CallStage(
      cloud, "health", params,
      [&](testing::StageInputs& in) -> absl::Status {
        SCANPREP_ASSIGN_OR_RETURN(health, MeasureHealth(in.cloud, in.measures, in.neighbourhoods,
                                                        in.Settings(HealthParams()), ran, in.out));
        return absl::OkStatus();
      },
      stages);
  EXPECT_TRUE(report.ok()) << report.status();
  return health;
}

PairHealth OnlyPair(const HealthReport& health) {
  EXPECT_EQ(health.pairs.size(), 1u);
  if (health.pairs.empty()) return {};
  EXPECT_EQ(health.pairs[0].fixed, 0u);
  EXPECT_EQ(health.pairs[0].moving, 1u);
  return health.pairs[0];
}

// The motion that maps fixed's surface onto moving's points, linearised at c (relative to the
// cloud's origin): translation R c + t − c and rotation vector, as the stage reports them.
struct Truth {
  Eigen::Vector3d translation_mm, rotation_deg;
};
Truth TruthAt(const Eigen::Isometry3d& motion, const Eigen::Vector3d& c_local,
              const Eigen::Vector3d& origin) {
  const Eigen::Vector3d c = c_local + origin;
  const Eigen::AngleAxisd aa(motion.linear());
  return {motion * c - c, aa.axis() * aa.angle() / kDegree};
}

// Within `share` of each truth component, or `floor_mm` (1 µm) / 0.005° where that is more.
void ExpectRecovered(const Eigen::Isometry3d& motion, double share = 0.2, double floor_mm = 1e-3) {
  sim::SimulatedCloud sim = TwoScans(Part::kBoxWithBore, motion);
  const HealthReport health = Health(sim.cloud);
  const PairHealth pair = OnlyPair(health);
  ASSERT_GE(pair.overlap_points, 1000u);
  const Truth truth = TruthAt(motion, pair.centre, sim.cloud.origin);
  for (int k = 0; k < 3; ++k) {
    EXPECT_TRUE(pair.constrained[k] && pair.constrained[k + 3]) << pair.note;
    EXPECT_NEAR(pair.translation_mm[k], truth.translation_mm[k],
                std::max(share * std::abs(truth.translation_mm[k]), floor_mm))
        << kMisalignmentAxes[k];
    EXPECT_NEAR(pair.rotation_deg[k], truth.rotation_deg[k],
                std::max(share * std::abs(truth.rotation_deg[k]), 0.005))
        << kMisalignmentAxes[k + 3];
  }
}

Eigen::Isometry3d Shift(const Eigen::Vector3d& t) {
  Eigen::Isometry3d m = Eigen::Isometry3d::Identity();
  m.translation() = t;
  return m;
}

Eigen::Isometry3d Turn(double degrees, const Eigen::Vector3d& axis) {
  return Eigen::Isometry3d(Eigen::AngleAxisd(degrees * kDegree, axis));
}

TEST(Health, AlignedScansReportNoMisalignment) {
  sim::SimulatedCloud sim = TwoScans(Part::kBoxWithBore, Eigen::Isometry3d::Identity());
  const PairHealth pair = OnlyPair(Health(sim.cloud));
  EXPECT_LT(pair.translation_mm.norm(), 1e-3);
  EXPECT_LT(pair.rotation_deg.norm(), 0.005);
  EXPECT_TRUE(pair.note.empty()) << pair.note;
}

TEST(Health, ShiftAlongEachAxisIsRecoveredWithItsSign) {
  for (double microns : {5.0, 20.0}) {
    for (int axis = 0; axis < 3; ++axis) {
      SCOPED_TRACE(::testing::Message() << microns << " µm along " << kMisalignmentAxes[axis]);
      ExpectRecovered(Shift(Eigen::Vector3d::Unit(axis) * microns * 1e-3));
    }
  }
}

TEST(Health, RotationAboutEachAxisIsRecoveredAtTheReportedCentre) {
  for (double degrees : {0.02, 0.05}) {
    for (int axis = 0; axis < 3; ++axis) {
      SCOPED_TRACE(::testing::Message() << degrees << "° about " << kMisalignmentAxes[axis + 3]);
      ExpectRecovered(Turn(degrees, Eigen::Vector3d::Unit(axis)));
    }
  }
}

// A misregistration far above the noise: its residuals spread far beyond the scans' noise, and
// a robust pass that judged them by the wrong scale would keep only the few near zero.
TEST(Health, LargeMisregistrationIsRecoveredWithinFivePercent) {
  Eigen::Isometry3d motion = Turn(0.3, Eigen::Vector3d(1, 1, 0).normalized());
  motion.translation() = Eigen::Vector3d(0.05, 0, 0);
  ExpectRecovered(motion, 0.05);
}

// A misregistration of several times the pair's combined noise along the axis most of the overlap
// constrains (z, the top face): read within the documented 20 % along its axis (across it, within
// 1 µm or 1 % of the shift). The control, a shift of one σ, lies within the robust cut of both
// passes wherever that cut is centred.
TEST(Health, ShiftOfSeveralNoiseSigmasAlongAConstrainedAxisIsRecovered) {
  const std::vector<sim::SimSensor> sensors = sim::TwoOverlappingSensors(Part::kBoxWithBore);
  const double sigma = std::hypot(sensors[0].noise_sigma, sensors[1].noise_sigma);
  for (double sigmas : {1.0, 3.0, 5.0, 10.0}) {
    SCOPED_TRACE(::testing::Message()
                 << sigmas << " σ = " << sigmas * sigma * 1e3 << " µm along z");
    ExpectRecovered(Shift({0, 0, sigmas * sigma}), 0.2, std::max(1e-3, 0.01 * sigmas * sigma));
  }
}

// Three scans, the third 10 µm up: one pair per two scans, in (fixed, moving) order, and only
// the pairs with the third read the shift, with its sign (moving is the higher index).
TEST(Health, EveryOverlappingPairIsReportedOnceInOrder) {
  std::vector<sim::SimSensor> sensors = sim::ThreeOverlappingSensors(Part::kBoxWithBore);
  sensors[2].misregistration = Shift({0, 0, 0.01});
  sim::SimulatedCloud sim = sim::SimulateWithPointCount(Part::kBoxWithBore, sensors, kPoints, 0, 7);
  const HealthReport health = Health(sim.cloud);
  ASSERT_EQ(health.pairs.size(), 3u);
  const std::array<std::pair<uint32_t, uint32_t>, 3> order = {{{0, 1}, {0, 2}, {1, 2}}};
  for (size_t p = 0; p < 3; ++p) {
    const PairHealth& pair = health.pairs[p];
    EXPECT_EQ(std::pair(pair.fixed, pair.moving), order[p]);
    ASSERT_TRUE(pair.constrained[2]) << pair.note;
    EXPECT_NEAR(pair.translation_mm.z(), pair.moving == 2 ? 0.01 : 0.0, 0.002) << p;
  }
}

// Issue 39 finding 8: 30 scans of one plate overlap in hundreds of pairs; the report keeps 256 of
// them (those with the most overlap points), in (fixed, moving) order.
TEST(Health, AReportKeepsTheLargestOverlapsWhenScansOverlapInManyPairs) {
  PointCloud cloud;
  cloud.kind = ScannerKind::kLine;
  std::mt19937 rng(3);
  std::normal_distribution<float> noise(0.f, 0.01f);
  for (uint32_t s = 0; s < 30; ++s) {
    cloud.scans.push_back(ScanMeta{.id = absl::StrCat("plate", s),
                                   .view_direction = Eigen::Vector3d::UnitZ(),
                                   .scanline_spacing = 0.5,
                                   .uncertainty = 0.01});
    for (int r = 0; r < 40; ++r) {
      for (int c = 0; c < 40; ++c) {
        cloud.x.push_back(0.5f * c + 0.25f * (s % 2));
        cloud.y.push_back(0.5f * r + 0.02f * s);
        cloud.z.push_back(noise(rng));
        cloud.scan.push_back(s);
        cloud.scanline.push_back(static_cast<uint32_t>(r));
      }
    }
  }
  cloud.FinishLoading();
  const HealthReport health = Health(cloud);
  ASSERT_EQ(health.pairs.size(), kMaxReportedPairs);
  for (size_t p = 1; p < health.pairs.size(); ++p) {
    EXPECT_LT(std::tie(health.pairs[p - 1].fixed, health.pairs[p - 1].moving),
              std::tie(health.pairs[p].fixed, health.pairs[p].moving));
  }
}

TEST(Health, FlatOverlapFlagsTheInPlaneComponentsAndDoesNotGuessThem) {
  // 20 µm along x and along z: the plane z = 0 sees only the second.
  sim::SimulatedCloud sim = TwoScans(Part::kPlane, Shift({0.02, 0, 0.02}));
  const PairHealth pair = OnlyPair(Health(sim.cloud));
  const std::array<bool, 6> expected = {false, false, true, true, true, false};
  EXPECT_EQ(pair.constrained, expected);
  EXPECT_EQ(pair.note, "too flat to constrain tx, ty, rz");
  EXPECT_EQ(pair.translation_mm.x(), 0);
  EXPECT_EQ(pair.translation_mm.y(), 0);
  EXPECT_EQ(pair.rotation_deg.z(), 0);
  EXPECT_NEAR(pair.translation_mm.z(), 0.02, 0.2 * 0.02);
}

TEST(Health, TooSmallAnOverlapConstrainsNothing) {
  // 20 k points: an overlap of a few thousand, below the largest minimum a job may ask for.
  std::vector<sim::SimSensor> sensors = sim::TwoOverlappingSensors(Part::kBoxWithBore);
  sensors[1].misregistration = Shift({0, 0, 0.02});
  sim::SimulatedCloud sim = sim::SimulateWithPointCount(Part::kBoxWithBore, sensors, 20'000, 0, 7);
  const PairHealth pair =
      OnlyPair(Health(sim.cloud, {"health"}, {{"health.min_overlap_points", "10000"}}));
  ASSERT_GT(pair.overlap_points, 0u);
  ASSERT_LT(pair.overlap_points, 10'000u);
  EXPECT_EQ(pair.constrained, (std::array<bool, 6>{}));
  EXPECT_EQ(pair.translation_mm, Eigen::Vector3d::Zero());
  // Nothing was solved: no component is stated as known (a 0 would read "exactly").
  EXPECT_TRUE(pair.translation_se_mm.array().isInf().all());
  EXPECT_TRUE(pair.rotation_se_deg.array().isInf().all());
  EXPECT_EQ(pair.note,
            "overlap too small (" + std::to_string(pair.overlap_points) + " points < 10000)");
}

TEST(Health, ResidualSpreadIsTheCombinedNoiseOfBothScans) {
  // Range noise along the camera ray, σ/cos q, seen along the normal: at least σ per scan.
  sim::SimulatedCloud sim = TwoScans(Part::kBoxWithBore, Shift({0, 0, 0.01}));
  const std::vector<sim::SimSensor> sensors = sim::TwoOverlappingSensors(Part::kBoxWithBore);
  const double combined = std::hypot(sensors[0].noise_sigma, sensors[1].noise_sigma);
  const PairHealth pair = OnlyPair(Health(sim.cloud));
  EXPECT_GT(pair.residual_spread_mm, combined);
  EXPECT_LT(pair.residual_spread_mm, 1.6 * combined);
}

TEST(Health, NoiseFollowsTheSensorsTrueNoise) {
  std::vector<double> noise;
  for (double scale : {1.0, 1.5, 2.0}) {
    sim::SimulatedCloud sim = TwoScans(Part::kBoxWithBore, Eigen::Isometry3d::Identity(), scale);
    const HealthReport health = Health(sim.cloud);
    ASSERT_EQ(health.scans.size(), 2u);
    ASSERT_TRUE(health.scans[1].noise_mm.has_value());
    noise.push_back(*health.scans[1].noise_mm);
    const double u = sim.cloud.scans[1].uncertainty;
    EXPECT_NEAR(*health.scans[1].noise_to_uncertainty, noise.back() / u, 1e-12);
  }
  EXPECT_NEAR(noise[1] / noise[0], 1.5, 0.15);
  EXPECT_NEAR(noise[2] / noise[0], 2.0, 0.2);
}

TEST(Health, ScanFiguresCountWhatTheStagesBeforeRemoved) {
  sim::SimulatedCloud sim = TwoScans(Part::kBoxWithBore, Eigen::Isometry3d::Identity());
  PointCloud copy = sim.cloud;
  const HealthReport alone = Health(sim.cloud);
  ASSERT_EQ(alone.scans.size(), 2u);
  // Health alone: no stage removed anything before it, so the shares are not known.
  EXPECT_FALSE(alone.scans[0].outlier_share.has_value());
  EXPECT_FALSE(alone.scans[0].merged_share.has_value());
  const HealthReport after = Health(copy, {"outliers", "correction", "health"});
  size_t merged = 0, in_scan = 0;
  for (size_t i = 0; i < copy.size(); ++i) {
    if (copy.scan[i] != 1) continue;
    ++in_scan;
    merged += (copy.flags[i] & kRemovedMerge) != 0;
  }
  EXPECT_EQ(after.scans[1].points, in_scan);
  ASSERT_TRUE(after.scans[1].merged_share.has_value());
  EXPECT_GT(merged, 0u);
  EXPECT_DOUBLE_EQ(*after.scans[1].merged_share, double(merged) / double(in_scan));
  ASSERT_TRUE(after.scans[1].outlier_share.has_value());
  // The viewing angles against the true ones (true normal, camera ray). Normal noise (σ = 20 µm
  // on the oblique scan) widens the spread, so the outer deciles get a wider margin.
  for (uint32_t scan : {0u, 1u}) {
    std::vector<double> truth;
    for (size_t i = 0; i < sim.cloud.size(); ++i) {
      if (sim.cloud.scan[i] != scan) continue;
      const Eigen::Vector3d t = sim.truth[i].cast<double>();
      const Eigen::Vector3d ray = (*sim.cloud.scans[scan].camera_position - t).normalized();
      truth.push_back(std::acos(std::abs(ray.dot(sim.true_normal[i].cast<double>()))) / kDegree);
    }
    std::sort(truth.begin(), truth.end());
    ASSERT_TRUE(alone.scans[scan].viewing_angle_deg.has_value());
    const std::array<double, 3>& reported = *alone.scans[scan].viewing_angle_deg;
    for (int q = 0; q < 3; ++q) {
      const double expected = truth[static_cast<size_t>((0.1 + 0.4 * q) * (truth.size() - 1))];
      EXPECT_NEAR(reported[q], expected, q == 1 ? 1.5 : 4.0)
          << "scan " << scan << " decile " << 1 + 4 * q;
    }
  }
}

// Of every point a sensor delivered, the share that had no position (ScanMeta::points_invalid:
// left out by a reader or by the server) never reached the pipeline.
TEST(Health, InvalidShareIsTheUnmeasuredShareOfWhatTheSensorDelivered) {
  sim::SimulatedCloud sim = TwoScans(Part::kBoxWithBore, Eigen::Isometry3d::Identity());
  const size_t in_scan = std::count(sim.cloud.scan.begin(), sim.cloud.scan.end(), 1u);
  sim.cloud.scans[1].points_invalid = in_scan / 4;
  const HealthReport health = Health(sim.cloud);
  ASSERT_EQ(health.scans.size(), 2u);
  EXPECT_EQ(health.scans[0].invalid_share, 0.0);
  EXPECT_DOUBLE_EQ(health.scans[1].invalid_share,
                   double(in_scan / 4) / double(in_scan + in_scan / 4));
}

// On a plane both sensors see whole, the merge removes most of the worse-viewed scan; its noise is
// still the sensor's, measured over every point it delivered.
TEST(Health, NoiseCountsThePointsTheMergeRemoved) {
  std::vector<sim::SimSensor> sensors = sim::TwoOverlappingSensors(Part::kPlane);
  sim::SimulatedCloud sim = sim::SimulateWithPointCount(Part::kPlane, sensors, kPoints, 0, 7);
  const HealthReport health = Health(sim.cloud, {"correction", "health"});
  ASSERT_EQ(health.scans.size(), 2u);
  ASSERT_TRUE(health.scans[1].merged_share.has_value());
  EXPECT_GT(*health.scans[1].merged_share, 0.5);
  ASSERT_TRUE(health.scans[0].noise_mm.has_value());
  ASSERT_TRUE(health.scans[1].noise_mm.has_value());
  double sum2[2] = {0, 0}, count[2] = {0, 0};
  for (size_t i = 0; i < sim.cloud.size(); ++i) {
    const double offset = (sim.cloud.point(i) - sim.truth[i]).dot(sim.true_normal[i]);
    sum2[sim.cloud.scan[i]] += offset * offset;
    ++count[sim.cloud.scan[i]];
  }
  const double truth = std::sqrt(sum2[1] / count[1]) / std::sqrt(sum2[0] / count[0]);
  // The median fit residual weighs the grazing (noisiest) parts of the oblique scan less than the
  // RMS does: its ratio lies between the sensors' σ ratio (2) and the true RMS ratio (3.3).
  const double ratio = *health.scans[1].noise_mm / *health.scans[0].noise_mm;
  EXPECT_GE(ratio, sensors[1].noise_sigma / sensors[0].noise_sigma);
  EXPECT_LE(ratio, truth);
}

// A client may state any count (ScanHeader.points_unmeasured): the share stays within [0, 1].
TEST(Health, AnAbsurdUnmeasuredCountCannotWrapTheShare) {
  sim::SimulatedCloud sim = TwoScans(Part::kBoxWithBore, Eigen::Isometry3d::Identity());
  sim.cloud.scans[0].points_invalid = std::numeric_limits<uint64_t>::max();
  const HealthReport health = Health(sim.cloud);
  ASSERT_EQ(health.scans.size(), 2u);
  EXPECT_GT(health.scans[0].invalid_share, 0.999);
  EXPECT_LE(health.scans[0].invalid_share, 1.0);
}

TEST(Health, AbsentUnlessTheJobRunsIt) {
  sim::SimulatedCloud sim = TwoScans(Part::kBoxWithBore, Eigen::Isometry3d::Identity());
  CancelToken cancel;
  auto report = RunPipeline(sim.cloud, {.stages = {"outliers", "smoothing"}}, cancel);
  ASSERT_TRUE(report.ok()) << report.status();
  EXPECT_FALSE(report->health.has_value());
  for (const StageReport& stage : report->stages) EXPECT_NE(stage.name, "health");
}

}  // namespace
}  // namespace scanprep
