// SPDX-License-Identifier: Apache-2.0
// A PointAttribute's values as doubles and one made from doubles, for the tests' expectations
// (the attribute stores them in its own type's bytes).
#pragma once

#include <string>
#include <vector>

#include "core/base/point_attributes.h"

namespace scanprep::testing {

inline std::vector<double> Values(const PointAttribute& attribute) {
  std::vector<double> values;
  for (size_t i = 0; i < attribute.size(); ++i) values.push_back(attribute.Value(i));
  return values;
}

inline PointAttribute MakeAttribute(std::string name, AttributeType type,
                                    const std::vector<double>& values) {
  PointAttribute attribute{.name = std::move(name), .type = type};
  for (double v : values) attribute.Append(v);
  return attribute;
}

}  // namespace scanprep::testing
