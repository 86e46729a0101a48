// SPDX-License-Identifier: Apache-2.0
// Parallel loops that honour cancellation. Every stage loops through here so a cancelled job
// stops within one block of work instead of finishing the stage.
#pragma once

#include <algorithm>
#include <cstddef>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>

#include "core/pipeline/cancel.h"
#include "core/pipeline/happens_before.h"

namespace scanprep {

// Calls body(begin, end) over [0, n) in blocks of grain/2 to grain indices; blocks that start
// after cancellation are skipped, and each finished block is counted in the token's work meter
// (progress). Returns CANCELLED if the token fired at any point of the loop.
// The simple partitioner keeps blocks at the grain: TBB's default one hands a thread ranges of
// many grains when nothing is stolen, so a cancel waited for tens of thousands of points.
template <typename Body>
absl::Status ParallelFor(size_t n, const CancelToken& cancel, Body&& body, size_t grain = 1024) {
  // Separate fork and join tags, so blocks are not ordered among themselves for TSan.
  const char fork = 0, join = 0;
  HappensBefore(&fork);
  tbb::parallel_for(
      tbb::blocked_range<size_t>(0, n, grain),
      [&](const tbb::blocked_range<size_t>& r) {
        HappensAfter(&fork);
        if (!cancel.cancelled()) {
          body(r.begin(), r.end());
          cancel.Worked(r.size());
        }
        HappensBefore(&join);
      },
      tbb::simple_partitioner());
  HappensAfter(&join);
  return cancel.Check();
}

// Sorts `items` by operator< and honours cancellation, unlike tbb::parallel_sort: blocks of 2^16
// elements are sorted in parallel, then runs are merged pairwise, round by round, the merges of
// a round in parallel. The token is looked at between blocks and rounds, so a cancel waits for
// at most one merge (the last round's is one pass over all elements). Not stable.
template <typename T>
absl::Status CancellableSort(std::vector<T>& items, const CancelToken& cancel) {
  constexpr size_t kBlock = size_t{1} << 16;
  const size_t n = items.size();
  const size_t blocks = (n + kBlock - 1) / kBlock;
  absl::Status status = ParallelFor(
      blocks, cancel,
      [&](size_t begin, size_t end) {
        for (size_t b = begin; b < end; ++b) {
          std::sort(items.begin() + b * kBlock, items.begin() + std::min(n, (b + 1) * kBlock));
        }
      },
      1);
  if (!status.ok() || n <= kBlock) return status;
  std::vector<T> merged(n);
  for (size_t width = kBlock; width < n; width *= 2) {
    status =
        ParallelFor((n + 2 * width - 1) / (2 * width), cancel,
                    [&](size_t begin, size_t end) {
                      for (size_t p = begin; p < end; ++p) {
                        const size_t lo = 2 * width * p, mid = std::min(n, lo + width);
                        const size_t hi = std::min(n, mid + width);
                        std::merge(items.begin() + lo, items.begin() + mid, items.begin() + mid,
                                   items.begin() + hi, merged.begin() + lo);
                      }
                    },
                    1);
    if (!status.ok()) return status;
    items.swap(merged);
  }
  return absl::OkStatus();
}

}  // namespace scanprep
