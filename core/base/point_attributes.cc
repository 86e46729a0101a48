// SPDX-License-Identifier: Apache-2.0
#include "core/base/point_attributes.h"

namespace scanprep {

int AttributeBytes(AttributeType type) {
  switch (type) {
    case AttributeType::kInt8:
    case AttributeType::kUint8:
      return 1;
    case AttributeType::kInt16:
    case AttributeType::kUint16:
      return 2;
    case AttributeType::kInt32:
    case AttributeType::kUint32:
    case AttributeType::kFloat32:
    case AttributeType::kFloat32Bits:
      return 4;
    case AttributeType::kFloat64:
      return 8;
  }
  return 8;
}

bool IsIntegerAttribute(AttributeType type) {
  return type != AttributeType::kFloat32 && type != AttributeType::kFloat64 &&
         type != AttributeType::kFloat32Bits;
}

bool IsSignedAttribute(AttributeType type) {
  return type == AttributeType::kInt8 || type == AttributeType::kInt16 ||
         type == AttributeType::kInt32 || !IsIntegerAttribute(type);
}

std::vector<PointAttribute> GatherAttributes(const std::vector<PointAttribute>& from,
                                             const std::vector<uint32_t>& positions) {
  std::vector<PointAttribute> out;
  out.reserve(from.size());
  for (const PointAttribute& attribute : from) {
    PointAttribute& gathered = out.emplace_back();
    gathered.name = attribute.name;
    gathered.type = attribute.type;
    gathered.values.reserve(positions.size());
    for (uint32_t p : positions) gathered.values.push_back(attribute.values[p]);
  }
  return out;
}

}  // namespace scanprep
