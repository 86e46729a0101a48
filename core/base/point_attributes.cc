// SPDX-License-Identifier: Apache-2.0
#include "core/base/point_attributes.h"

#include <algorithm>

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

std::vector<PointAttribute> JoinAttributes(
    const std::vector<const std::vector<PointAttribute>*>& parts,
    std::vector<std::vector<std::string>>& left_out) {
  const auto has = [](const std::vector<PointAttribute>& part, const PointAttribute& attribute) {
    return std::any_of(part.begin(), part.end(), [&](const PointAttribute& a) {
      return a.name == attribute.name && a.type == attribute.type;
    });
  };
  std::vector<PointAttribute> joined;
  for (const PointAttribute& first : parts.empty() ? std::vector<PointAttribute>{} : *parts[0]) {
    if (std::all_of(parts.begin(), parts.end(), [&](auto* part) { return has(*part, first); })) {
      joined.push_back({.name = first.name, .type = first.type});
    }
  }
  left_out.assign(parts.size(), {});
  for (size_t p = 0; p < parts.size(); ++p) {
    for (const PointAttribute& a : *parts[p]) {
      auto kept = std::find_if(joined.begin(), joined.end(),
                               [&](const PointAttribute& k) { return k.name == a.name; });
      if (kept == joined.end() || kept->type != a.type) {
        left_out[p].push_back(a.name);
      } else {
        kept->values.insert(kept->values.end(), a.values.begin(), a.values.end());
      }
    }
  }
  return joined;
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
