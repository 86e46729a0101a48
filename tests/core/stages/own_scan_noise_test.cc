// SPDX-License-Identifier: Apache-2.0
// σ̂ of one scan must not depend on how many other scans lie over it (issue 42): a plane with noise
// σ = 10 µm seen by a scan of 3,000 points, sent alone (the control) and with 1 to 199 other
// scans of the same plane over it. Without the own-point measure the normals fits of a scan under
// N others hold about 63/N of its points, and σ̂ read 0.86 of the single scan's at 8 scans and 0
// at 200.
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "core/stages/scan_noise.h"
#include "tests/support/stage_call.h"

namespace scanprep {
namespace {

constexpr double kSigma = 0.01;    // mm, along the plane's normal
constexpr size_t kPerScan = 3000;  // points a scan
constexpr double kSide = 10;       // mm: the square every scan covers (0.18 mm spacing)

// `scans` scans of the plane z = 0 over the same square, uniform in x, y, noise σ along z.
PointCloud Overlapping(size_t scans) {
  PointCloud cloud;
  std::mt19937 random(3);
  std::uniform_real_distribution<float> across(0, kSide);
  std::normal_distribution<float> noise(0, kSigma);
  for (uint32_t s = 0; s < scans; ++s) {
    for (size_t i = 0; i < kPerScan; ++i) {
      cloud.x.push_back(across(random));
      cloud.y.push_back(across(random));
      cloud.z.push_back(noise(random));
      cloud.scan.push_back(s);
    }
    ScanMeta meta;
    meta.id = "s" + std::to_string(s);
    meta.camera_position = Eigen::Vector3d(5, 5, 300);
    meta.uncertainty = kSigma;
    cloud.scans.push_back(meta);
  }
  cloud.FinishLoading();
  return cloud;
}

// Scan 0's σ̂ and how many scans the normals stage measured from their own points.
std::pair<double, double> FirstScanNoise(size_t scans) {
  PointCloud cloud = Overlapping(scans);
  double noise = 0, from_own = 0;
  auto report = testing::CallStage(
      cloud, "measures", {},
      [&](testing::StageInputs& in) -> absl::Status {
        SCANPREP_ASSIGN_OR_RETURN(auto measured,
                                  MeasuredScanNoise(in.cloud, in.measures, scans, in.out.cancel()));
        noise = measured[0].value_or(0);
        return absl::OkStatus();
      },
      {"measures"});
  EXPECT_TRUE(report.ok()) << report.status();
  for (const StageReport& stage : report.ok() ? report->stages : std::vector<StageReport>{}) {
    if (stage.name == "normals")
      from_own = stage.parameters.at("normals.scans_noise_from_own_points");
  }
  return {noise, from_own};
}

TEST(OwnScanNoise, AScansNoiseIsTheSameUnderAnyNumberOfOverlappingScans) {
  const auto [alone, none_from_own] = FirstScanNoise(1);
  EXPECT_EQ(none_from_own, 0);  // one scan: the normals fits themselves
  // σ̂ is the median fit residual, a little below σ (NoiseBounds): not 0, not far from σ.
  EXPECT_GT(alone, 0.6 * kSigma);
  EXPECT_LT(alone, 1.1 * kSigma);
  for (size_t scans : {2, 3, 4, 5, 6, 8, 32, 200}) {
    SCOPED_TRACE(::testing::Message() << scans << " scans");
    const auto [noise, from_own] = FirstScanNoise(scans);
    std::printf("%zu scans: σ̂ %.5f mm (alone %.5f), %g from own points\n", scans, noise, alone,
                from_own);
    EXPECT_NEAR(noise, alone, 0.1 * alone);
    // Up to three scans the normals balls hold 21 or more of their own points; from five on the
    // own fits take over (four lie at the share that decides).
    if (scans <= 3) EXPECT_EQ(from_own, 0);
    if (scans >= 5) EXPECT_EQ(from_own, double(scans));
  }
}

}  // namespace
}  // namespace scanprep
