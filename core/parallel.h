// Parallel loops that honour cancellation. Every stage loops through here so a cancelled job
// stops within one block of work instead of finishing the stage.
#pragma once

#include <algorithm>
#include <cstddef>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include "core/cancel.h"
#include "core/happens_before.h"

namespace scanprep {

// Calls body(begin, end) over [0, n) in blocks; blocks that start after cancellation are
// skipped. Returns CANCELLED if the token fired at any point of the loop.
template <typename Body>
absl::Status ParallelFor(size_t n, const CancelToken& cancel, Body&& body, size_t grain = 1024) {
  // Separate fork and join tags, so blocks are not ordered among themselves for TSan.
  const char fork = 0, join = 0;
  HappensBefore(&fork);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, grain),
                    [&](const tbb::blocked_range<size_t>& r) {
                      HappensAfter(&fork);
                      if (!cancel.cancelled()) body(r.begin(), r.end());
                      HappensBefore(&join);
                    });
  HappensAfter(&join);
  return cancel.Check();
}

// tbb::parallel_sort, except in ThreadSanitizer builds: there its tasks hand the elements between
// threads inside uninstrumented libtbb, where no annotation reaches, so those builds sort serially.
template <typename It>
void ParallelSort(It first, It last) {
#ifdef SCANPREP_TSAN
  std::sort(first, last);
#else
  tbb::parallel_sort(first, last);
#endif
}

}  // namespace scanprep
