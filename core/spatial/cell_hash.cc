// SPDX-License-Identifier: Apache-2.0
#include "core/spatial/cell_hash.h"

#include <random>

namespace scanprep {
namespace {

uint64_t Mix(uint64_t h) {  // splitmix64's finaliser
  h ^= h >> 30;
  h *= 0xbf58476d1ce4e5b9ull;
  h ^= h >> 27;
  h *= 0x94d049bb133111ebull;
  return h ^ (h >> 31);
}

uint64_t HashKey() {
  static const uint64_t key = uint64_t{std::random_device()()} << 32 | std::random_device()();
  return key;
}

}  // namespace

uint64_t HashCell(int64_t a, int64_t b, int64_t c) {
  return Mix(HashKey() ^ uint64_t(a) ^ Mix(uint64_t(b) ^ Mix(uint64_t(c))));
}

}  // namespace scanprep
