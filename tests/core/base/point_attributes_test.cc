// SPDX-License-Identifier: Apache-2.0
// Attributes of clouds joined end to end (a job's files, an E57 file's scans) and gathered for the
// points a job returned: what every part has, in order, and nothing silently dropped; each value
// held in its own type's bytes.
#include "core/base/point_attributes.h"

#include <cmath>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tests/support/attribute_values.h"

namespace scanprep {
namespace {

using ::testing::ElementsAre;
using testing::MakeAttribute;
using testing::Values;

TEST(PointAttributes, JoinKeepsWhatEveryPartHasInOneTypeAndNamesTheRest) {
  const std::vector<PointAttribute> first = {
      MakeAttribute("red", AttributeType::kUint8, {1, 2}),
      MakeAttribute("time", AttributeType::kFloat64, {0.5, 0.75})};
  const std::vector<PointAttribute> second = {
      MakeAttribute("time", AttributeType::kFloat32, {9}),  // another type
      MakeAttribute("red", AttributeType::kUint8, {3}),
      MakeAttribute("label", AttributeType::kInt32, {7})};  // only here
  std::vector<std::vector<std::string>> left_out;
  const std::vector<PointAttribute> joined = JoinAttributes({&first, &second}, left_out);
  ASSERT_EQ(joined.size(), 1u);
  EXPECT_EQ(joined[0].name, "red");
  EXPECT_EQ(joined[0].type, AttributeType::kUint8);
  EXPECT_THAT(Values(joined[0]), ElementsAre(1, 2, 3));  // the parts' points in order
  EXPECT_THAT(left_out[0], ElementsAre("time"));
  EXPECT_THAT(left_out[1], ElementsAre("time", "label"));
}

TEST(PointAttributes, GatherTakesTheNamedPositions) {
  const std::vector<PointAttribute> sent = {
      MakeAttribute("red", AttributeType::kUint8, {10, 11, 12, 13})};
  const std::vector<PointAttribute> back = GatherAttributes(sent, {0, 2, 3});
  ASSERT_EQ(back.size(), 1u);
  EXPECT_EQ(back[0].type, AttributeType::kUint8);
  EXPECT_THAT(Values(back[0]), ElementsAre(10, 12, 13));
}

// Values are held in their type's bytes, not as doubles (a colour channel of 100 M points is
// 100 MB, not 800 MB), and every type keeps its extreme values exactly, through a conversion too.
TEST(PointAttributes, EachValueTakesItsTypesBytesAndKeepsItsValue) {
  struct Case {
    AttributeType type;
    size_t bytes;  // the C type's size
    std::vector<double> values;
  };
  const std::vector<Case> cases = {
      {AttributeType::kInt8, 1, {-128, 0, 127}},
      {AttributeType::kUint8, 1, {0, 255}},
      {AttributeType::kInt16, 2, {-32768, 32767}},
      {AttributeType::kUint16, 2, {0, 65535}},
      {AttributeType::kInt32, 4, {-2147483648.0, 2147483647.0}},
      {AttributeType::kUint32, 4, {0, 4294967295.0}},
      {AttributeType::kFloat32, 4, {-3.4028234663852886e38, 1.401298464324817e-45, 0.1f}},
      {AttributeType::kFloat32Bits, 4, {0x7fa00000, 0xff0000ff}},  // a signalling NaN's bits
      {AttributeType::kFloat64, 8, {1e300, -0.1, 5e-324}},
  };
  for (const Case& c : cases) {
    for (double v : c.values) EXPECT_TRUE(HoldsValue(c.type, v)) << v;
    const PointAttribute a = MakeAttribute("v", c.type, c.values);
    EXPECT_EQ(a.data.size(), c.values.size() * c.bytes);
    EXPECT_EQ(Values(a), c.values);
    PointAttribute wide = a;
    wide.ConvertTo(AttributeType::kFloat64);
    EXPECT_EQ(Values(wide), c.values);
    EXPECT_EQ(wide.data.size(), 8 * c.values.size());
  }
}

// A value a type cannot hold: just past each extreme, a fraction for an integer type, NaN for an
// integer type, beyond float's range for a float (converting any of them is undefined).
TEST(PointAttributes, HoldsValueRefusesWhatTheTypeCannotHold) {
  const std::vector<std::pair<AttributeType, std::vector<double>>> cases = {
      {AttributeType::kInt8, {-129, 128, 0.5}},
      {AttributeType::kUint8, {-1, 256, NAN}},
      {AttributeType::kInt16, {-32769, 32768}},
      {AttributeType::kUint16, {-1, 65536}},
      {AttributeType::kInt32, {-2147483649.0, 2147483648.0, 1.5}},
      {AttributeType::kUint32, {-1, 4294967296.0, INFINITY}},
      {AttributeType::kFloat32, {3.5e38, -1e39}},
      {AttributeType::kFloat32Bits, {-1, 4294967296.0, 0.25}},
  };
  for (const auto& [type, values] : cases) {
    for (double v : values) EXPECT_FALSE(HoldsValue(type, v)) << static_cast<int>(type) << " " << v;
  }
  EXPECT_TRUE(HoldsValue(AttributeType::kFloat32, INFINITY));  // a float's own values
  EXPECT_TRUE(HoldsValue(AttributeType::kFloat32, NAN));
  EXPECT_TRUE(HoldsValue(AttributeType::kFloat64, 1e308));
}

}  // namespace
}  // namespace scanprep
