// Parallel loops that honour cancellation. Every stage loops through here so a cancelled job
// stops within one block of work instead of finishing the stage.
#pragma once

#include <cstddef>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "core/cancel.h"

namespace scanprep {

// Calls body(begin, end) over [0, n) in blocks; blocks that start after cancellation are
// skipped. Returns CANCELLED if the token fired at any point of the loop.
template <typename Body>
absl::Status ParallelFor(size_t n, const CancelToken& cancel, Body&& body, size_t grain = 1024) {
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, grain),
                    [&](const tbb::blocked_range<size_t>& r) {
                      if (cancel.cancelled()) return;
                      body(r.begin(), r.end());
                    });
  return cancel.Check();
}

}  // namespace scanprep
