// SPDX-License-Identifier: Apache-2.0
// All seven stages through the service: on the ten registered Stanford bunny scans, with each
// scan's viewing direction determined from its own data, and on a simulated two-scan part with
// known surface.
#include <cmath>
#include <numbers>
#include <random>

#include <gtest/gtest.h>
#include <Eigen/Eigenvalues>

#include "core/pipeline/pipeline.h"
#include "core/sim/scan_simulator.h"
#include "tests/server/bunny_job.h"
#include "tests/server/service_fixtures.h"
#include "tests/support/kdtree.h"
#include "tests/support/test_data.h"

namespace scanprep::testing {
namespace {

// In the order they ran: the outliers stage's surface test pulls in the normals first.
const std::vector<std::string> kAllStages = {"neighbourhoods", "normals",    "outliers",
                                             "measures",       "correction", "smoothing",
                                             "simplification"};

// One scan of the job, converted from metres to the millimetres core works in.
PointCloud ScanOf(const PointCloud& all, uint32_t scan) {
  PointCloud one;
  for (size_t i = 0; i < all.size(); ++i) {
    if (all.scan[i] != scan) continue;
    one.x.push_back(1000 * all.x[i]);
    one.y.push_back(1000 * all.y[i]);
    one.z.push_back(1000 * all.z[i]);
  }
  return one;
}

// The report's stage names, without the neighbourhood rebuild that follows smoothing (it moved
// the points); checks that each stage starts with the points the one before it left.
std::vector<std::string> StageNames(const v1::Report& report) {
  std::vector<std::string> names;
  for (int s = 0; s < report.stages_size(); ++s) {
    const v1::StageReport& stage = report.stages(s);
    std::cout << stage.name() << ": " << stage.points_in() << " -> " << stage.points_out() << " in "
              << stage.seconds() << " s\n";
    if (s > 0) {
      EXPECT_EQ(stage.points_in(), report.stages(s - 1).points_out());
    }
    if (stage.name() == "neighbourhoods" && !names.empty()) continue;
    names.push_back(stage.name());
  }
  return names;
}

double Parameter(const v1::Report& report, const std::string& stage, const std::string& name) {
  for (const v1::StageReport& s : report.stages()) {
    if (s.name() == stage) return s.parameters().at(name);
  }
  ADD_FAILURE() << "no stage " << stage;
  return 0;
}

// The direction from a single range scan toward its sensor, in the scan's own frame, from the
// points alone. A range scan sees only surface that faces the sensor, so its consistently
// oriented normals all lie within about 80° of the viewing direction: the axis is the direction
// whose worst-aligned normals (5th percentile of n·v) align best, found on a Fibonacci sphere
// and refined around the best node. That fixes the axis up to the normals' arbitrary common sign;
// the sign comes from the shape: a range scan of a compact part sees a cap whose middle lies
// nearer the sensor than its rim, so depth along the axis falls with the distance from its centre.
Eigen::Vector3d ViewDirectionFromData(PointCloud scan) {
  scan.scans = {ScanMeta{.id = "scan"}};
  scan.kind = ScannerKind::kFlexible;
  scan.FinishLoading();
  CancelToken cancel;
  auto report = RunPipeline(scan, {.stages = {"normals"}}, cancel);
  EXPECT_TRUE(report.ok()) << report.status();
  std::vector<Eigen::Vector3d> normals;
  for (size_t i = 0; i < scan.size(); i += std::max<size_t>(1, scan.size() / 4000)) {
    if (!(scan.flags[i] & kNormalInvalid)) normals.push_back(scan.normal(i).cast<double>());
  }
  std::vector<double> dots(normals.size());
  auto score = [&](const Eigen::Vector3d& v) {
    for (size_t i = 0; i < normals.size(); ++i) dots[i] = normals[i].dot(v);
    std::nth_element(dots.begin(), dots.begin() + dots.size() / 20, dots.end());
    return dots[dots.size() / 20];
  };
  Eigen::Vector3d best = Eigen::Vector3d::UnitZ();
  double best_score = -2;
  const int nodes = 5000;
  for (int k = 0; k < nodes; ++k) {
    const double z = 1 - 2 * (k + 0.5) / nodes, r = std::sqrt(1 - z * z);
    const double phi = k * std::numbers::pi * (3 - std::sqrt(5.0));
    const Eigen::Vector3d v(r * std::cos(phi), r * std::sin(phi), z);
    if (const double s = score(v); s > best_score) best_score = s, best = v;
  }
  std::mt19937 rng(1);
  std::normal_distribution<double> jitter(0, 0.01);
  for (int k = 0; k < 2000; ++k) {
    const Eigen::Vector3d v =
        (best + Eigen::Vector3d(jitter(rng), jitter(rng), jitter(rng))).normalized();
    if (const double s = score(v); s > best_score) best_score = s, best = v;
  }
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < scan.size(); ++i) centroid += scan.point(i).cast<double>();
  centroid /= static_cast<double>(scan.size());
  double sd = 0, sr = 0, sdr = 0;
  for (size_t i = 0; i < scan.size(); ++i) {
    const Eigen::Vector3d p = scan.point(i).cast<double>() - centroid;
    const double depth = p.dot(best), radius = (p - depth * best).norm();
    sd += depth, sr += radius, sdr += depth * radius;
  }
  const double n = static_cast<double>(scan.size());
  return sdr / n - (sd / n) * (sr / n) < 0 ? best : -best;
}

double AngleDegrees(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)) * 180 /
         std::numbers::pi;
}

Eigen::Quaterniond Rotation(const v1::ScanHeader& scan) {
  const v1::Quaternion& q = scan.to_common().rotation();
  return Eigen::Quaterniond(q.w(), q.x(), q.y(), q.z());
}

// Share of points (of the given scans' kept points) with a point of another scan closer than
// `spacing`: how much of the cloud is a doubled layer.
double DoubledShare(const PointCloud& cloud, const std::vector<bool>& kept, double spacing) {
  PointCloud live;
  for (size_t i = 0; i < cloud.size(); ++i) {
    if (!kept[i]) continue;
    live.x.push_back(cloud.x[i]);
    live.y.push_back(cloud.y[i]);
    live.z.push_back(cloud.z[i]);
    live.scan.push_back(cloud.scan[i]);
  }
  KdTree tree(live);
  RadiusMatches matches;
  size_t doubled = 0;
  for (size_t i = 0; i < live.size(); ++i) {
    const float q[3] = {live.x[i], live.y[i], live.z[i]};
    tree.Radius(q, static_cast<float>(spacing), matches);
    doubled += std::any_of(matches.begin(), matches.end(),
                           [&](const auto& m) { return live.scan[m.first] != live.scan[i]; });
  }
  return double(doubled) / double(live.size());
}

// Establishes the scanner geometry the bunny jobs use: in every scan's own frame the Cyberware
// sensor sits on +z (looks along −z). The pose rotations then put the turntable scans at their
// registered angles around the bunny.
// Share of points whose nearest point of another scan (within `radius`) has a normal on the same
// side: a scan whose sensor side were wrong would have every normal flipped against its
// neighbours'.
double CrossScanNormalAgreement(const PointCloud& cloud, const std::vector<bool>& use,
                                double radius) {
  KdTree tree(cloud);
  RadiusMatches matches;
  size_t pairs = 0, agree = 0;
  for (size_t i = 0; i < cloud.size(); i += 7) {
    if (!use[i] || (cloud.flags[i] & kNormalInvalid)) continue;
    const float q[3] = {cloud.x[i], cloud.y[i], cloud.z[i]};
    tree.Radius(q, static_cast<float>(radius), matches);
    float best = radius * radius;
    size_t other = cloud.size();
    for (const auto& [j, d2] : matches) {
      if (use[j] && cloud.scan[j] != cloud.scan[i] && !(cloud.flags[j] & kNormalInvalid) &&
          d2 < best) {
        best = d2, other = j;
      }
    }
    if (other == cloud.size()) continue;
    ++pairs;
    agree += cloud.normal(i).dot(cloud.normal(other)) > 0;
  }
  return pairs ? double(agree) / double(pairs) : 0;
}

TEST(FullPipeline, BunnyScannerSitsOnPlusZOfEachScanFrame) {
  SCANPREP_REQUIRE_SHARED_DATA(data);
  const BunnyJob job = LoadBunny(data / "stanford_bunny_range_scans");
  for (int s = 0; s < job.header.scans_size(); ++s) {
    const v1::ScanHeader& scan = job.header.scans(s);
    const Eigen::Vector3d own = ViewDirectionFromData(ScanOf(job.points, s));
    const double off_z = AngleDegrees(own, Eigen::Vector3d::UnitZ());
    std::cout << scan.scan_id() << ": view direction from the data (" << own.transpose() << "), "
              << off_z << "° from +z; in the common frame "
              << AngleDegrees(Rotation(scan) * own,
                              Rotation(job.header.scans(0)) * Eigen::Vector3d::UnitZ())
              << "° from bun000's +z\n";
    EXPECT_LT(off_z, 20.0) << scan.scan_id();
  }
}

TEST(FullPipeline, AllSevenStagesOnTheRegisteredBunny) {
  SCANPREP_REQUIRE_SHARED_DATA(data);
  BunnyJob job = LoadBunny(data / "stanford_bunny_range_scans");
  std::vector<Eigen::Vector3d> view_common;
  for (int s = 0; s < job.header.scans_size(); ++s) {
    v1::ScanHeader* scan = job.header.mutable_scans(s);
    // +z of the scan's own frame: see BunnyScannerSitsOnPlusZOfEachScanFrame.
    const Eigen::Vector3d own = Eigen::Vector3d::UnitZ();
    scan->mutable_view_direction()->set_z(1);
    // Cyberware 3030 rows are about 0.82 mm apart, points 0.56 mm along a row (data README).
    scan->set_scanline_spacing(0.00082);
    scan->set_point_spacing(0.00056);
    scan->set_uncertainty(0.0001);
    view_common.push_back(Rotation(*scan) * own);
  }
  for (const std::string& stage : kAllStages) job.header.mutable_options()->add_stages(stage);
  job.header.mutable_options()->set_include_removed(true);

  InProcessServer server;
  auto result = server.Client().Process(job.header, job.points);
  ASSERT_TRUE(result.ok()) << result.status();
  const v1::Report& report = result->report;
  EXPECT_EQ(StageNames(report), kAllStages);
  EXPECT_GT(Parameter(report, "outliers", "outliers.removed"), 0);
  EXPECT_GT(Parameter(report, "correction", "correction.removed"), 0);
  EXPECT_GT(Parameter(report, "smoothing", "smoothing.moved"), 0);
  EXPECT_GT(Parameter(report, "simplification", "simplification.removed"), 0);

  const PointCloud& out = result->cloud;  // every point, metres, common frame, with flags
  ASSERT_EQ(out.size(), 362'272u);
  std::vector<bool> after_outliers(out.size()), kept(out.size());
  size_t facing = 0, valid = 0;
  for (size_t i = 0; i < out.size(); ++i) {
    after_outliers[i] = (out.flags[i] & kRemovedOutlier) == 0;
    kept[i] = (out.flags[i] & kRemovedMask) == 0;
    if (!after_outliers[i] || (out.flags[i] & kNormalInvalid)) continue;
    ++valid;
    facing += out.normal(i).cast<double>().dot(view_common[out.scan[i]]) > 0;
  }
  EXPECT_EQ(report.points_returned(), out.size());
  const double facing_share = double(facing) / double(valid);
  std::cout << "normals facing their scanner: " << 100 * facing_share << " % of " << valid << "\n";
  EXPECT_GE(facing_share, 0.95);
  const double agreement = CrossScanNormalAgreement(out, after_outliers, 0.00056);
  std::cout << "normals agreeing with the nearest other scan's: " << 100 * agreement << " %\n";
  EXPECT_GE(agreement, 0.95);

  // Overlaps thinned to one layer: closer than the scanner's 0.56 mm point spacing.
  const double before = DoubledShare(out, after_outliers, 0.00056);
  const double after = DoubledShare(out, kept, 0.00056);
  std::cout << "points with another scan's point within 0.56 mm: " << 100 * before << " % before, "
            << 100 * after << " % after\n";
  EXPECT_GT(before, 0.5);
  EXPECT_LT(after, 0.15);
}

TEST(FullPipeline, AllSevenStagesOnASimulatedPart) {
  const auto part = sim::Part::kBoxWithBore;
  auto sensors = sim::TwoOverlappingSensors(part);
  for (auto& s : sensors) s.outlier_fraction = 0.01;
  const sim::SimulatedCloud simulated = sim::Simulate(part, sensors, 5);
  v1::JobHeader header;
  header.set_job_id("box");
  header.set_unit(v1::LENGTH_UNIT_MILLIMETRE);
  for (const ScanMeta& meta : simulated.cloud.scans) {
    v1::ScanHeader* scan = header.add_scans();
    scan->set_scan_id(meta.id);
    scan->mutable_camera_position()->set_x(meta.camera_position->x());
    scan->mutable_camera_position()->set_y(meta.camera_position->y());
    scan->mutable_camera_position()->set_z(meta.camera_position->z());
    scan->mutable_projector_direction()->set_x(meta.projector_direction->x());
    scan->mutable_projector_direction()->set_y(meta.projector_direction->y());
    scan->mutable_projector_direction()->set_z(meta.projector_direction->z());
    scan->set_scanline_spacing(meta.scanline_spacing);
    scan->set_point_spacing(meta.point_spacing);
    scan->set_uncertainty(meta.uncertainty);
  }
  for (const std::string& stage : kAllStages) header.mutable_options()->add_stages(stage);
  header.mutable_options()->set_include_removed(true);

  InProcessServer server;
  auto result = server.Client().Process(header, simulated.cloud);
  ASSERT_TRUE(result.ok()) << result.status();
  EXPECT_EQ(StageNames(result->report), kAllStages);
  const PointCloud& out = result->cloud;
  ASSERT_EQ(out.size(), simulated.cloud.size());

  size_t spikes = 0, spikes_removed = 0, kept = 0;
  double before_sq = 0, after_sq = 0;
  for (size_t i = 0; i < out.size(); ++i) {
    if (simulated.is_outlier[i]) {
      ++spikes;
      spikes_removed += (out.flags[i] & kRemovedMask) != 0;
      continue;
    }
    if (out.flags[i] & kRemovedMask) continue;
    ++kept;
    const double d0 = sim::DistanceToSurface(part, simulated.cloud.point(i).cast<double>());
    const double d1 = sim::DistanceToSurface(part, out.point(i).cast<double>());
    before_sq += d0 * d0;
    after_sq += d1 * d1;
  }
  const double rms_before = std::sqrt(before_sq / kept), rms_after = std::sqrt(after_sq / kept);
  std::cout << "spikes removed " << spikes_removed << "/" << spikes << "; kept " << kept << " of "
            << out.size() << "; RMS to the true surface " << rms_before << " -> " << rms_after
            << " mm\n";
  EXPECT_GE(spikes_removed, 0.75 * spikes);
  EXPECT_LT(rms_after, rms_before);
  EXPECT_LT(kept, out.size() / 2);  // correction and simplification thinned it
}

}  // namespace
}  // namespace scanprep::testing
