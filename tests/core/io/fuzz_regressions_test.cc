// SPDX-License-Identifier: Apache-2.0
// Inputs the fuzzers (tests/fuzz) found mishandled, inlined so the fixes stay fixed.
#include <sstream>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "core/io/conf.h"
#include "core/io/pcd.h"
#include "core/io/ply.h"

namespace scanprep::io {
namespace {

using ::testing::HasSubstr;

// ply_fuzzer and pcd_fuzzer: an ASCII value its declared type cannot hold (300 for a uchar, 1.5
// for an int, 1e39 for a float) was cast to the type, which is undefined; each is refused by
// name, and the type's own extremes (the control) are read.
TEST(FuzzRegressions, AsciiPlyValueOutsideItsTypeIsRefusedByName) {
  const std::string header =
      "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
      "property float z\nproperty uchar red\nproperty int label\nproperty float "
      "gloss\nend_header\n";
  const auto read = [&](const std::string& vertex) {
    std::istringstream in(header + vertex + "\n");
    std::vector<std::string> warnings;
    return ReadPly(in, "a.ply", warnings);
  };
  const auto control = read("1 2 3 255 -2147483648 1e38");
  ASSERT_TRUE(control.ok()) << control.status();
  ASSERT_EQ(control->attributes.size(), 3u);
  EXPECT_EQ(control->attributes[0].Value(0), 255);
  EXPECT_EQ(control->attributes[1].Value(0), -2147483648.0);
  EXPECT_THAT(read("1 2 3 300 0 0").status().message(),
              HasSubstr("vertex 0: 'red' value 300: not a value of the property's type"));
  EXPECT_THAT(read("1 2 3 0 1.5 0").status().message(),
              HasSubstr("'label' value 1.5: not a value of the property's type"));
  EXPECT_THAT(read("1 2 3 -1 0 0").status().message(), HasSubstr("'red' value -1: not a value"));
  EXPECT_THAT(read("1 2 3 0 0 1e39").status().message(),
              HasSubstr("'gloss' value 1e+39: not a value of the property's type"));
}

TEST(FuzzRegressions, AsciiPcdValueOutsideItsTypeIsRefusedByName) {
  const std::string header =
      "VERSION 0.7\nFIELDS x y z label flags\nSIZE 4 4 4 1 1\nTYPE F F F U U\n"
      "COUNT 1 1 1 1 1\nWIDTH 1\nHEIGHT 1\nPOINTS 1\nDATA ascii\n";
  const auto read = [&](const std::string& point) {
    std::istringstream in(header + point + "\n");
    std::vector<std::string> warnings;
    return ReadPcd(in, "a.pcd", warnings);
  };
  const auto control = read("1 2 3 255 255");
  ASSERT_TRUE(control.ok()) << control.status();
  ASSERT_EQ(control->attributes.size(), 1u);
  EXPECT_EQ(control->attributes[0].Value(0), 255);
  EXPECT_THAT(read("1 2 3 256 0").status().message(),
              HasSubstr("field 'label' value '256' is not a value of its TYPE U SIZE 1"));
  EXPECT_THAT(read("1 2 3 0 300").status().message(), HasSubstr("field 'flags' value '300'"));
  EXPECT_THAT(read("1 2 1e39 0 0").status().message(), HasSubstr("field 'z' value '1e39'"));
}

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
