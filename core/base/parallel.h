// SPDX-License-Identifier: Apache-2.0
// Parallel loops that honour cancellation. Every stage loops through here so a cancelled job
// stops within one block of work instead of finishing the stage.
#pragma once

#include <algorithm>
#include <cstddef>
#include <memory>
#include <utility>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>

#include "core/base/cancel.h"
#include "core/base/happens_before.h"

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
          const CancelToken* outer = std::exchange(running_loop_token, &cancel);
          body(r.begin(), r.end());
          running_loop_token = outer;
          cancel.Worked(r.size());
        }
        HappensBefore(&join);
      },
      tbb::simple_partitioner());
  HappensAfter(&join);
  return cancel.Check();
}

// Sums block(begin, end), which returns a T, over [0, n) in fixed blocks of `grain` indices and
// adds the blocks' sums in block order into `sum`: the same result on any number of threads (a
// floating-point sum depends on its order). T needs `+=`; `zero` is its neutral value.
template <typename T, typename Block>
absl::Status ParallelSum(size_t n, const CancelToken& cancel, const T& zero, Block&& block, T& sum,
                         size_t grain = 4096) {
  const size_t blocks = (n + grain - 1) / grain;
  std::vector<T> partial(blocks, zero);
  absl::Status status = ParallelFor(
      blocks, cancel,
      [&](size_t first, size_t last) {
        for (size_t b = first; b < last; ++b) {
          partial[b] = block(b * grain, std::min(n, (b + 1) * grain));
        }
      },
      1);
  sum = zero;
  for (const T& part : partial) sum += part;
  return status;
}

// Merges the sorted runs run[0, left) and run[left, left + right) into run[0, left + right),
// moving the shorter run to `aside` (room for min(left, right) items) first: with the left one
// aside the merge fills from the front, with the right one from the back, and never overwrites
// an item not yet read.
template <typename T>
void MergeInPlace(T* run, size_t left, size_t right, T* aside) {
  if (left == 0 || right == 0) return;
  if (left <= right) {
    std::move(run, run + left, aside);
    T *a = aside, *a_end = aside + left;
    T *r = run + left, *r_end = run + left + right, *out = run;
    while (a < a_end && r < r_end) *out++ = *r < *a ? std::move(*r++) : std::move(*a++);
    std::move(a, a_end, out);  // what is left of the right run is in place already
  } else {
    std::move(run + left, run + left + right, aside);
    T *a = aside + right, *a_begin = aside;
    T *l = run + left, *out = run + left + right;
    while (a > a_begin && l > run) {
      *--out = *(a - 1) < *(l - 1) ? std::move(*--l) : std::move(*--a);
    }
    std::move_backward(a_begin, a, out);  // what is left of the left run is in place already
  }
}

// Sorts `items` by operator< and honours cancellation, unlike tbb::parallel_sort: blocks of 2^16
// elements are sorted in parallel, then runs are merged pairwise, round by round, the merges of
// a round in parallel. The token is looked at between blocks and rounds, so a cancel waits for
// at most one merge (the last round's is one pass over all elements). Not stable. A merge moves
// the shorter of its two runs aside and merges into their place, so the sort needs half the
// items' size on top of them, not a second copy (the peak of a large job's sorts).
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
  // The merge of [lo, hi) moves at most (hi − lo) / 2 items aside, to [lo / 2, hi / 2): the
  // merges of a round never share a slot.
  const auto aside = std::make_unique_for_overwrite<T[]>(n / 2);
  for (size_t width = kBlock; width < n; width *= 2) {
    status = ParallelFor((n + 2 * width - 1) / (2 * width), cancel,
                         [&](size_t begin, size_t end) {
                           for (size_t p = begin; p < end; ++p) {
                             const size_t lo = 2 * width * p, mid = std::min(n, lo + width);
                             MergeInPlace(items.data() + lo, mid - lo,
                                          std::min(n, mid + width) - mid, aside.get() + lo / 2);
                           }
                         },
                         1);
    if (!status.ok()) return status;
  }
  return absl::OkStatus();
}

}  // namespace scanprep
