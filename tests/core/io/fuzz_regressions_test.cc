// SPDX-License-Identifier: Apache-2.0
// Inputs the fuzzers (tests/fuzz) found mishandled, inlined so the fixes stay fixed.
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "core/io/conf.h"

namespace scanprep::io {
namespace {

// conf_fuzzer: a quaternion component of 1e200 overflowed the plain norm to inf, so the
// "normalised" rotation became the zero quaternion and every point collapsed onto the translation.
TEST(FuzzRegressions, ConfQuaternionWithHugeComponentsIsNormalisedNotZeroed) {
  std::istringstream in("bmesh a.ply 1 2 3 1e200 0 0 1\n");
  auto entries = ReadConf(in, "huge.conf");
  ASSERT_TRUE(entries.ok()) << entries.status();
  ASSERT_EQ(entries->size(), 1u);
  const RigidPose& pose = (*entries)[0].pose;
  // (1e200, 0, 0, 1) normalises to the half-turn about x, q = (1, 0, 0, 0); the stored rotation is
  // its conjugate, which rotates the same way (a half-turn is its own inverse).
  EXPECT_NEAR(pose.rotation.norm(), 1.0, 1e-12);
  EXPECT_NEAR(std::abs(pose.rotation.x()), 1.0, 1e-12);
  const Eigen::Vector3d moved = Apply(pose, Eigen::Vector3d(0, 1, 0));
  EXPECT_TRUE(moved.isApprox(Eigen::Vector3d(1, 1, 3), 1e-9)) << moved.transpose();
}

}  // namespace
}  // namespace scanprep::io
