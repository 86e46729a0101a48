// SPDX-License-Identifier: Apache-2.0
// Byte swapping between the host and a file's declared byte order.
#pragma once

#include <algorithm>
#include <bit>
#include <cstring>

namespace scanprep::io {

inline constexpr bool kHostIsBigEndian = std::endian::native == std::endian::big;

template <class T>
T ByteSwapped(T value) {
  unsigned char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  std::reverse(bytes, bytes + sizeof(T));
  std::memcpy(&value, bytes, sizeof(T));
  return value;
}

}  // namespace scanprep::io
