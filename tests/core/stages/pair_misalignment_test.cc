// SPDX-License-Identifier: Apache-2.0
// The pair estimate called directly, on correspondences whose truth is known exactly: a flat patch
// of the fixed scan, the moving scan's points above it by a known shift plus noise of a known σ
// (every match weighted alike), and a tenth of the matches glints far above the surface. The
// robust cut must keep the surface and drop the glints wherever the surface lies: around the
// residuals' median, not around 0.
#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "core/stages/pair_misalignment.h"

namespace scanprep {
namespace {

constexpr double kSigma = 0.02;      // mm, every match's residual noise
constexpr double kGlintHeight = 30;  // σ above the surface
constexpr size_t kPoints = 20'000;   // matches on a 100 mm square
constexpr size_t kGlintEvery = 10;   // one match in ten is a glint

// The tilt's standard error: σ / (√(surface matches) · the square's RMS lever 100/√12 mm), in
// degrees (3e-4°).
const double kTiltNoiseDeg =
    kSigma / (std::sqrt(kPoints * 0.9) * 100 / std::sqrt(12.0)) * 180 / std::numbers::pi;

struct Patch {
  PointCloud cloud;
  std::vector<Correspondence> matches;
};

// Fixed points on z = 0 (scan 0), each matched with a moving point (scan 1) `shift` mm above it
// plus N(0, σ), or kGlintHeight σ above it for every kGlintEvery-th match; each match states its
// noise as `stated_sigma`.
Patch FlatPatchShiftedBy(double shift, double stated_sigma = kSigma) {
  Patch patch;
  PointCloud& c = patch.cloud;
  std::mt19937 random(11);
  std::uniform_real_distribution<float> across(-50, 50);
  std::normal_distribution<double> noise(0, kSigma);
  const auto add = [&c](float x, float y, double z, uint32_t scan) {
    c.x.push_back(x);
    c.y.push_back(y);
    c.z.push_back(static_cast<float>(z));
    c.scan.push_back(scan);
    return static_cast<uint32_t>(c.size() - 1);
  };
  for (size_t i = 0; i < kPoints; ++i) {
    const float x = across(random), y = across(random);
    const double up = i % kGlintEvery == 0 ? kGlintHeight * kSigma : shift + noise(random);
    const uint32_t fixed = add(x, y, 0, 0);
    patch.matches.push_back(
        {.moving = add(x, y, up, 1), .fixed = fixed, .sigma = static_cast<float>(stated_sigma)});
  }
  c.scans.resize(2);
  c.FinishLoading();
  return patch;
}

PairHealth Estimate(const Patch& patch) {
  CancelToken cancel;
  absl::StatusOr<PairHealth> pair =
      EstimatePairHealth(patch.cloud, 0, 1, patch.matches, MisalignmentSettings{}, cancel);
  EXPECT_TRUE(pair.ok()) << pair.status();
  return pair.value_or(PairHealth{});
}

// The shift is read along the patch's normal within 0.1 σ, the glints (which alone would add
// 3 σ) cut away, and the in-plane components flagged. A shift of 0 is the control: there a cut
// centred on 0 and one centred on the median agree; at 10 σ and beyond only the median's keeps
// the surface.
TEST(PairMisalignment, TheRobustCutFollowsTheSurfaceToAnyShiftAndDropsTheGlints) {
  for (double sigmas : {0.0, 10.0, 100.0}) {
    const double shift = sigmas * kSigma;
    SCOPED_TRACE(testing::Message() << sigmas << " σ = " << shift << " mm along z");
    const PairHealth pair = Estimate(FlatPatchShiftedBy(shift));
    EXPECT_EQ(pair.overlap_points, kPoints);
    ASSERT_TRUE(pair.constrained[2]) << pair.note;  // tz
    EXPECT_NEAR(pair.translation_mm.z(), shift, 0.1 * kSigma);
    EXPECT_TRUE(pair.constrained[3] && pair.constrained[4]) << pair.note;  // rx, ry
    EXPECT_NEAR(pair.rotation_deg.x(), 0, kTiltNoiseDeg * 4);
    EXPECT_NEAR(pair.rotation_deg.y(), 0, kTiltNoiseDeg * 4);
    EXPECT_FALSE(pair.constrained[0] || pair.constrained[1] || pair.constrained[5]);
    EXPECT_EQ(pair.note, "too flat to constrain tx, ty, rz");
  }
}

void ExpectStandardErrors(const PairHealth& pair) {
  const double along_normal = kSigma / std::sqrt(kPoints * 0.9);
  EXPECT_NEAR(pair.translation_se_mm.z(), along_normal, 0.2 * along_normal);
  EXPECT_NEAR(pair.rotation_se_deg.x(), kTiltNoiseDeg, 0.2 * kTiltNoiseDeg);
  EXPECT_NEAR(pair.rotation_se_deg.y(), kTiltNoiseDeg, 0.2 * kTiltNoiseDeg);
  for (int k : {0, 1}) EXPECT_GT(pair.translation_se_mm[k], 100 * along_normal);
  EXPECT_GT(pair.rotation_se_deg.z(), 100 * kTiltNoiseDeg);
}

// Independent residuals of a known σ: each standard error is what least squares gives for that
// noise, σ/√(surface matches) along the normal and kTiltNoiseDeg for the two tilts (within 20 %:
// the jackknife's own spread over 32 groups is about 13 %), whatever noise the matches state
// (the residuals' spread says how far off that is); the in-plane components are flagged with
// standard errors far beyond the limit (the normal equations hold nothing along them).
TEST(PairMisalignment, StandardErrorsAreTheNoiseOverTheRootOfTheMatches) {
  for (double stated : {kSigma, 2 * kSigma}) {
    SCOPED_TRACE(testing::Message() << "stated σ " << stated << " mm");
    ExpectStandardErrors(Estimate(FlatPatchShiftedBy(0.01, stated)));
  }
}

}  // namespace
}  // namespace scanprep
