// SPDX-License-Identifier: Apache-2.0
// CancellableSort sorts as std::sort does at every shape of its merge rounds: one block, a run
// without a partner, a last pair whose right run is the shorter (merged from the back) or the
// longer (from the front), with many equal items; and stops with CANCELLED when asked.
#include <algorithm>
#include <random>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "core/base/parallel.h"

namespace scanprep {
namespace {

constexpr size_t kBlock = size_t{1} << 16;  // CancellableSort's block

TEST(CancellableSort, SortsAsStdSortAtEveryShapeOfTheMergeRounds) {
  std::mt19937_64 rng(7);
  for (size_t n : {size_t{0}, size_t{1}, kBlock, kBlock + 1, 2 * kBlock, 3 * kBlock + 5,
                   5 * kBlock - 3, 16 * kBlock + 1}) {
    std::vector<std::pair<uint32_t, uint32_t>> items(n);
    // Few distinct keys: runs hold many equal keys, and the second member tells equal keys apart
    // (a merge that dropped or doubled an item would change the multiset).
    for (auto& item : items) item = {static_cast<uint32_t>(rng() % 1000), uint32_t(rng())};
    std::vector<std::pair<uint32_t, uint32_t>> expected = items;
    std::sort(expected.begin(), expected.end());
    CancelToken cancel;
    ASSERT_TRUE(CancellableSort(items, cancel).ok());
    EXPECT_EQ(items, expected) << n << " items";
  }
}

TEST(CancellableSort, DescendingInputMergesEveryRunFromBothEnds) {
  // Every item of a right run is smaller than every item of its left run: the merges move one
  // whole run past the other, the case where reading and writing come closest.
  std::vector<uint64_t> items(7 * kBlock + 11);
  for (size_t i = 0; i < items.size(); ++i) items[i] = items.size() - i;
  CancelToken cancel;
  ASSERT_TRUE(CancellableSort(items, cancel).ok());
  for (size_t i = 0; i < items.size(); ++i) ASSERT_EQ(items[i], i + 1) << "at " << i;
}

TEST(CancellableSort, ACancelledSortSaysSo) {
  std::vector<uint64_t> items(4 * kBlock, 1);
  CancelToken cancel;
  cancel.Cancel();
  EXPECT_EQ(CancellableSort(items, cancel).code(), absl::StatusCode::kCancelled);
}

}  // namespace
}  // namespace scanprep
