// SPDX-License-Identifier: Apache-2.0
// The grid's fallback for the queries its cells cannot answer with a bounded read: a kd-tree
// (nanoflann) over the grid's own copy of the points. A uniform grid reads every point of the
// cells a ball crosses, so its work per query depends on the distribution: a part far away on a
// diagonal stretches the cells until the whole scan shares a few of them, a cluster of
// near-identical points fills one cell with thousands, an isolated point's k nearest lie across
// thousands of empty columns. A kd-tree splits wherever the points are, so the k nearest (or the
// nearest `count` within a radius) cost O(log n + k) reads on any of them. CellGrid asks it only
// when its own read would exceed a fixed budget, so ordinary clouds never build it.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "absl/status/statusor.h"
#include "core/base/cancel.h"

namespace scanprep {

// A point's coordinates as the grid keeps them, next to their cell's.
struct GridEntry {
  float x, y, z;
};

// Points whose distance to a query was computed, by this thread's grid and tree queries so far:
// the work counter tests hold to a bound (a cliff in the index shows as a count, not a time).
inline thread_local uint64_t candidates_examined_by_this_thread = 0;

// Which points a tree query returns.
struct NearestQuery {
  float limit_sq = 0;  // only points with squared distance below this
  size_t count = 0;    // at most this many: the nearest, ties to the lower index; SIZE_MAX all
  uint32_t exclude = UINT32_MAX;   // this point index never
  const uint8_t* flags = nullptr;  // with `skip`: points whose flags & skip are left out
  uint8_t skip = 0;
};

class EntryTree {
 public:
  // A tree over `entries`, whose point indices are `ids` (both must outlive it and stay put);
  // Cancelled when `cancel` fires during the build.
  static absl::StatusOr<std::unique_ptr<EntryTree>> Build(std::span<const GridEntry> entries,
                                                          std::span<const uint32_t> ids,
                                                          const CancelToken& cancel);
  ~EntryTree();

  // The points `query` asks for, as keys (squared distance bits << 32 | point index: they order
  // by distance, then index), unsorted, into `keys`. Exact, and the same answer as the grid's:
  // the squared distance is summed as the grid and nanoflann sum it, no node that could hold a
  // point it keeps is pruned, and ties at the count's edge go to the lower index.
  void Nearest(const float q[3], const NearestQuery& query, std::vector<uint64_t>& keys) const;

 private:
  struct Index;
  explicit EntryTree(std::unique_ptr<Index> index);
  std::unique_ptr<Index> index_;
};

}  // namespace scanprep
