// SPDX-License-Identifier: Apache-2.0
// An even subset of a sequence: up to `cap` of its items, every (size / cap)-th, in order. Of
// points in index order a sample along the scanlines; of matches sorted by distance a subset with
// the whole set's spread of distances.
#pragma once

#include <cstddef>
#include <span>
#include <vector>

namespace scanprep {

template <typename T>
std::vector<T> Stride(std::span<const T> items, size_t cap) {
  if (items.size() <= cap) return {items.begin(), items.end()};
  std::vector<T> out(cap);
  for (size_t t = 0; t < cap; ++t) out[t] = items[t * items.size() / cap];
  return out;
}

template <typename T>
std::vector<T> Stride(const std::vector<T>& items, size_t cap) {
  return Stride(std::span<const T>(items), cap);
}

}  // namespace scanprep
