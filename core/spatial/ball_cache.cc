// SPDX-License-Identifier: Apache-2.0
#include "core/spatial/ball_cache.h"

#include <algorithm>
#include <atomic>
#include <utility>

#include "core/pipeline/parallel.h"

namespace scanprep {
namespace {

// Writes v at `out` (at most 5 bytes) and returns the end.
uint8_t* PutVarint(uint32_t v, uint8_t* out) {
  while (v >= 0x80) {
    *out++ = static_cast<uint8_t>(v | 0x80);
    v >>= 7;
  }
  *out++ = static_cast<uint8_t>(v);
  return out;
}

// A difference of two indices (mod 2^32) as an unsigned number that is small when the
// difference is small either way: 0, −1, 1, −2, … → 0, 1, 2, 3, …
uint32_t ZigZag(uint32_t delta) {
  return (delta << 1) ^ static_cast<uint32_t>(-static_cast<int32_t>(delta >> 31));
}
uint32_t UnZigZag(uint32_t v) { return (v >> 1) ^ (0u - (v & 1)); }

uint32_t GetVarint(const uint8_t*& p) {
  uint32_t v = 0;
  for (int shift = 0;; shift += 7) {
    const uint8_t byte = *p++;
    v |= uint32_t(byte & 0x7f) << shift;
    if (!(byte & 0x80)) return v;
  }
}

// Balls are asked in grid order (neighbouring balls read the same cells) in blocks of this many
// points, and the blocks in rounds of kBlocksPerRound: the budget is checked after each round,
// so which balls are kept does not depend on the threads' timing, and it is exceeded by at most
// one round's balls (4,096 points).
constexpr size_t kBlock = 1024;
constexpr size_t kBlocksPerRound = 4;

}  // namespace

size_t BallCache::PointsPerRound() { return kBlock * kBlocksPerRound; }

absl::Status BallCache::Gather(const PointCloud& cloud, const Neighbourhoods& nb,
                               const std::vector<float>& radius_of_scan,
                               const std::function<bool(const RadiusMatches&)>& keep,
                               const CancelToken& cancel) {
  const size_t n = cloud.size();
  const std::span<const uint32_t> order = nb.order();
  const size_t blocks = (n + kBlock - 1) / kBlock;
  const size_t budget = kBallCacheBytesPerPoint * n;
  blocks_.assign(blocks, {});
  state_.assign(n, Slot{});
  kept_ = over_budget_ = bytes_ = 0;
  std::atomic<size_t> kept{0}, over{0};
  for (size_t first = 0; first < blocks; first += kBlocksPerRound) {
    const bool room = bytes_ < budget;
    const size_t last = std::min(blocks, first + kBlocksPerRound);
    absl::Status status = ParallelFor(
        last - first, cancel,
        [&](size_t from, size_t to) {
          RadiusMatches matches;
          size_t local_kept = 0, local_over = 0;
          for (size_t b = first + from; b < first + to; ++b) {
            std::vector<uint8_t>& bytes = blocks_[b];
            for (size_t v = b * kBlock; v < std::min(n, (b + 1) * kBlock); ++v) {
              const uint32_t i = order[v];
              const float radius = radius_of_scan[cloud.scan[i]];
              if (cloud.removed(i) || radius <= nb.dk(i)) continue;
              nb.Within(cloud, i, radius, matches);
              if (!keep(matches)) {
                state_[i].block = kRejected;
                continue;
              }
              if (!room) {
                ++local_over;
                continue;
              }
              state_[i] = {static_cast<uint32_t>(b), static_cast<uint32_t>(bytes.size())};
              const size_t at = bytes.size();
              bytes.resize(at + 5 * (matches.size() + 1));
              uint8_t* end = PutVarint(static_cast<uint32_t>(matches.size()), bytes.data() + at);
              uint32_t previous = 0;
              for (const auto& match : matches) {
                end = PutVarint(ZigZag(match.first - std::exchange(previous, match.first)), end);
              }
              bytes.resize(static_cast<size_t>(end - bytes.data()));
              ++local_kept;
            }
            bytes.shrink_to_fit();
          }
          kept += local_kept;
          over += local_over;
        },
        /*grain=*/1);
    if (!status.ok()) return status;
    for (size_t b = first; b < last; ++b) bytes_ += blocks_[b].size();
  }
  kept_ = kept;
  over_budget_ = over;
  return absl::OkStatus();
}

void BallCache::Within(const PointCloud& cloud, const Neighbourhoods& nb, size_t i, float radius,
                       RadiusMatches& out) const {
  const Slot& slot = state_[i];
  if (slot.block == kNotKept || slot.block == kRejected) {
    nb.Within(cloud, i, radius, out);
    return;
  }
  out.clear();
  const uint8_t* p = blocks_[slot.block].data() + slot.begin;
  const uint32_t count = GetVarint(p);
  uint32_t j = 0;
  for (uint32_t m = 0; m < count; ++m) {
    j += UnZigZag(GetVarint(p));
    if (!cloud.removed(j)) out.emplace_back(j, cloud.squared_distance(i, j));
  }
}

}  // namespace scanprep
