// SPDX-License-Identifier: Apache-2.0
#include "core/base/point_attributes.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <type_traits>

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

namespace {

// Calls f(T{}) with T the C type a value of `type` is stored as: kFloat32Bits as the integer of
// its bit pattern. Value and Set share it, so the two cannot disagree on a type's storage.
template <class F>
auto WithStorageType(AttributeType type, F&& f) {
  switch (type) {
    case AttributeType::kInt8:
      return f(int8_t{});
    case AttributeType::kUint8:
      return f(uint8_t{});
    case AttributeType::kInt16:
      return f(int16_t{});
    case AttributeType::kUint16:
      return f(uint16_t{});
    case AttributeType::kInt32:
      return f(int32_t{});
    case AttributeType::kUint32:
    case AttributeType::kFloat32Bits:
      return f(uint32_t{});
    case AttributeType::kFloat32:
      return f(float{});
    case AttributeType::kFloat64:
      break;
  }
  return f(double{});
}

}  // namespace

double PointAttribute::Value(size_t i) const {
  const uint8_t* at = data.data() + i * AttributeBytes(type);
  return WithStorageType(type, [&](auto zero) {
    decltype(zero) value;
    std::memcpy(&value, at, sizeof value);
    return static_cast<double>(value);
  });
}

void PointAttribute::Set(size_t i, double value) {
  uint8_t* at = data.data() + i * AttributeBytes(type);
  WithStorageType(type, [&](auto zero) {
    const auto stored = static_cast<decltype(zero)>(value);
    std::memcpy(at, &stored, sizeof stored);
  });
}

void PointAttribute::Append(double value) {
  const size_t n = size();
  Resize(n + 1);
  Set(n, value);
}

void PointAttribute::ConvertTo(AttributeType to) {
  PointAttribute converted{.type = to};
  converted.Resize(size());
  for (size_t i = 0; i < size(); ++i) converted.Set(i, Value(i));
  type = to;
  data = std::move(converted.data);
}

bool IsIntegerAttribute(AttributeType type) {
  return type != AttributeType::kFloat32 && type != AttributeType::kFloat64 &&
         type != AttributeType::kFloat32Bits;
}

bool HoldsValue(AttributeType type, double value) {
  if (type == AttributeType::kFloat64) return true;
  return WithStorageType(type, [&](auto zero) {
    using T = decltype(zero);
    using Limits = std::numeric_limits<T>;
    if constexpr (std::is_floating_point_v<T>) {
      return !std::isfinite(value) || std::abs(value) <= static_cast<double>(Limits::max());
    } else {
      return value == std::trunc(value) && value >= static_cast<double>(Limits::min()) &&
             value <= static_cast<double>(Limits::max());
    }
  });
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
        kept->data.insert(kept->data.end(), a.data.begin(), a.data.end());
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
    const size_t bytes = AttributeBytes(attribute.type);
    gathered.data.resize(positions.size() * bytes);
    for (size_t k = 0; k < positions.size(); ++k) {
      std::memcpy(gathered.data.data() + k * bytes, attribute.data.data() + positions[k] * bytes,
                  bytes);
    }
  }
  return out;
}

}  // namespace scanprep
