// SPDX-License-Identifier: Apache-2.0
// Attributes of clouds joined end to end (a job's files, an E57 file's scans) and gathered for the
// points a job returned: what every part has, in order, and nothing silently dropped.
#include "core/base/point_attributes.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace scanprep {
namespace {

using ::testing::ElementsAre;

TEST(PointAttributes, JoinKeepsWhatEveryPartHasInOneTypeAndNamesTheRest) {
  const std::vector<PointAttribute> first = {
      {.name = "red", .type = AttributeType::kUint8, .values = {1, 2}},
      {.name = "time", .type = AttributeType::kFloat64, .values = {0.5, 0.75}}};
  const std::vector<PointAttribute> second = {
      {.name = "time", .type = AttributeType::kFloat32, .values = {9}},  // another type
      {.name = "red", .type = AttributeType::kUint8, .values = {3}},
      {.name = "label", .type = AttributeType::kInt32, .values = {7}}};  // only here
  std::vector<std::vector<std::string>> left_out;
  const std::vector<PointAttribute> joined = JoinAttributes({&first, &second}, left_out);
  ASSERT_EQ(joined.size(), 1u);
  EXPECT_EQ(joined[0].name, "red");
  EXPECT_EQ(joined[0].type, AttributeType::kUint8);
  EXPECT_THAT(joined[0].values, ElementsAre(1, 2, 3));  // the parts' points in order
  EXPECT_THAT(left_out[0], ElementsAre("time"));
  EXPECT_THAT(left_out[1], ElementsAre("time", "label"));
}

TEST(PointAttributes, GatherTakesTheNamedPositions) {
  const std::vector<PointAttribute> sent = {
      {.name = "red", .type = AttributeType::kUint8, .values = {10, 11, 12, 13}}};
  const std::vector<PointAttribute> back = GatherAttributes(sent, {0, 2, 3});
  ASSERT_EQ(back.size(), 1u);
  EXPECT_EQ(back[0].type, AttributeType::kUint8);
  EXPECT_THAT(back[0].values, ElementsAre(10, 12, 13));
}

}  // namespace
}  // namespace scanprep
