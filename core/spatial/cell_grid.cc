// SPDX-License-Identifier: Apache-2.0
#include "core/spatial/cell_grid.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>

#include "core/base/free_memory.h"
#include "core/base/parallel.h"
#include "core/base/status_macros.h"

namespace scanprep {
namespace {

constexpr int kMaxBitsPerAxis = 21;

// A point's cell key and index. The key is (column << z_bits | z cell); 32 bits hold it for
// every cloud whose grid has at most 2^32 cells (the common case), which halves the sort's
// memory, the grid's peak while it is rebuilt.
template <typename Key>
struct Keyed {
  Key key;
  uint32_t id;
};

// LSD radix sort on the low `bits` bits of the keys, 11 bits a pass; stable, so equal keys keep
// index order.
template <typename Key>
void RadixSort(std::vector<Keyed<Key>>& items, int bits) {
  constexpr int kDigit = 11;
  std::vector<Keyed<Key>> buffer(items.size());
  std::vector<size_t> count(size_t{1} << kDigit);
  for (int shift = 0; shift < bits; shift += kDigit) {
    std::fill(count.begin(), count.end(), 0);
    const uint64_t mask = (uint64_t{1} << kDigit) - 1;
    for (const auto& item : items) ++count[(item.key >> shift) & mask];
    if (count[(items.front().key >> shift) & mask] == items.size()) continue;  // one bucket
    size_t sum = 0;
    for (size_t& c : count) sum += std::exchange(c, sum);
    for (const auto& item : items) buffer[count[(item.key >> shift) & mask]++] = item;
    items.swap(buffer);
  }
}

// The box the grid covers: per axis the 1st to 99th percentile of a strided sample, widened by
// half that span on each side and clipped to the bounding box. A stray point far outside (a
// reflection at 1e8 mm) no longer stretches the cells until the whole scan shares one; it is
// kept in the outermost cell layer, which ForEachRun treats as reaching to infinity.
void RobustBox(const PointCloud& cloud, double lo[3], double hi[3]) {
  const size_t n = cloud.size();
  const size_t sample = std::min<size_t>(n, 8192);
  std::vector<float> v(sample);
  const std::vector<float>* axes[3] = {&cloud.x, &cloud.y, &cloud.z};
  for (int a = 0; a < 3; ++a) {
    const std::vector<float>& values = *axes[a];
    const auto [min, max] = std::minmax_element(values.begin(), values.end());
    for (size_t s = 0; s < sample; ++s) v[s] = values[s * n / sample];
    const size_t low = sample / 100, high = sample - 1 - sample / 100;
    std::nth_element(v.begin(), v.begin() + low, v.end());
    const double q_low = v[low];
    std::nth_element(v.begin(), v.begin() + high, v.end());
    const double q_high = v[high];
    const double margin = 0.5 * (q_high - q_low);
    lo[a] = std::max(double(*min), q_low - margin);
    hi[a] = std::min(double(*max), q_high + margin);
  }
}

}  // namespace

absl::Status CellGrid::Build(const PointCloud& cloud, float cell_edge, const CancelToken& cancel) {
  const size_t n = cloud.size();
  // Freed, not cleared: a rebuild (the points moved) would otherwise hold the old entries beside
  // the sort's two arrays of keys, the job's memory peak.
  fallback_ = std::make_unique<Fallback>();  // the old tree reads the entries freed next
  FreeMemory(entries_);
  FreeMemory(id_);
  cell_start_.assign(1, 0);
  cell_z_.clear();
  column_start_.assign(2, 0);
  cells_[0] = cells_[1] = cells_[2] = 1;
  key_bits_ = 0;
  if (n == 0) return absl::OkStatus();

  double lo[3], hi[3];
  RobustBox(cloud, lo, hi);
  const double extent = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]});
  double volume = 1;
  for (int a = 0; a < 3; ++a) volume *= std::max(hi[a] - lo[a], 1e-3 * extent);
  const double edge = cell_edge > 0 ? double(cell_edge) : std::cbrt(8 * volume / double(n));
  edge_ = std::max(edge, extent / double((1 << kMaxBitsPerAxis) - 2));
  // Bound the column table by 4 entries a point.
  const double table = (hi[0] - lo[0]) * (hi[1] - lo[1]);
  edge_ = std::max(edge_, std::sqrt(table / double(4 * n + 4096)));
  if (!(edge_ > 0) || !std::isfinite(edge_)) edge_ = 1;  // all points coincide
  inverse_edge_ = 1 / edge_;
  for (int a = 0; a < 3; ++a) {
    origin_[a] = lo[a];
    cells_[a] = static_cast<int64_t>(std::floor((hi[a] - lo[a]) * inverse_edge_)) + 1;
  }
  const int z_bits = std::bit_width(uint64_t(cells_[2] - 1));
  const uint64_t columns = uint64_t(cells_[0] * cells_[1]);

  key_bits_ = z_bits + std::bit_width(columns - 1);
  return key_bits_ <= 32 ? Sort<uint32_t>(cloud, z_bits, key_bits_, cancel)
                         : Sort<uint64_t>(cloud, z_bits, key_bits_, cancel);
}

template <typename Key>
absl::Status CellGrid::Sort(const PointCloud& cloud, int z_bits, int key_bits,
                            const CancelToken& cancel) {
  const size_t n = cloud.size();
  std::vector<Keyed<Key>> keyed(n);
  SCANPREP_RETURN_IF_ERROR(ParallelFor(n, cancel, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      const float p[3] = {cloud.x[i], cloud.y[i], cloud.z[i]};
      uint64_t c[3];
      for (int a = 0; a < 3; ++a) c[a] = static_cast<uint64_t>(PointCell(p[a], a));
      keyed[i] = {static_cast<Key>((c[0] * cells_[1] + c[1]) << z_bits | c[2]),
                  static_cast<uint32_t>(i)};
    }
  }));
  RadixSort(keyed, key_bits);
  SCANPREP_RETURN_IF_ERROR(cancel.Check());

  // The order and the cell tables from the keys, which are then freed before the entries are
  // filled: keys and entries together would be the rebuild's peak.
  id_.resize(n);
  cell_z_.clear();
  cell_start_.clear();
  column_start_.assign(uint64_t(cells_[0] * cells_[1]) + 1, 0);
  const uint64_t z_mask = (uint64_t{1} << z_bits) - 1;
  for (size_t e = 0; e < n; ++e) {
    id_[e] = keyed[e].id;
    if (e > 0 && keyed[e].key == keyed[e - 1].key) continue;
    cell_z_.push_back(static_cast<uint32_t>(keyed[e].key & z_mask));
    cell_start_.push_back(static_cast<uint32_t>(e));
    ++column_start_[(uint64_t(keyed[e].key) >> z_bits) + 1];
  }
  FreeMemory(keyed);
  cell_start_.push_back(static_cast<uint32_t>(n));
  for (size_t c = 0; c + 1 < column_start_.size(); ++c) column_start_[c + 1] += column_start_[c];

  entries_.resize(n);
  return ParallelFor(n, cancel, [&](size_t begin, size_t end) {
    for (size_t e = begin; e < end; ++e) {
      const uint32_t i = id_[e];
      entries_[e] = {cloud.x[i], cloud.y[i], cloud.z[i]};
    }
  });
}

bool CellGrid::CollectRuns(const float q[3], float radius, Runs& runs) const {
  runs.count = runs.candidates = 0;
  if (entries_.empty()) return true;
  // Padded so that float rounding in the caller's distance test cannot admit a point the cell
  // range missed; the range itself is computed in double.
  const double r = double(radius) * (1 + 1e-5) + 1e-30;
  const double reach = r * inverse_edge_;
  if (!(reach < 1e12)) return false;
  int64_t lo[3], hi[3];
  double c[3];
  for (int a = 0; a < 3; ++a) {
    // Clamped like the points' own cells: the outermost cells hold what lies beyond the box.
    c[a] = CellOf(q[a], a);
    lo[a] = ClampedCell(c[a] - reach, a);
    hi[a] = ClampedCell(c[a] + reach, a);
  }
  if (double(hi[0] - lo[0] + 1) * double(hi[1] - lo[1] + 1) > double(kMaxColumns)) return false;
  const double reach2 = reach * reach;
  // Distance (in cells) from q to cell v along an axis, 0 inside; the outermost cells reach to
  // infinity, as they hold every point beyond the box.
  auto gap = [&](int a, double cq, int64_t v) {
    const double low = v == 0 ? -HUGE_VAL : double(v);
    const double high = v == cells_[a] - 1 ? HUGE_VAL : double(v + 1);
    return cq < low ? low - cq : cq > high ? cq - high : 0.0;
  };
  for (int64_t x = lo[0]; x <= hi[0]; ++x) {
    const double gx = gap(0, c[0], x), rx = reach2 - gx * gx;
    if (rx < 0) continue;
    for (int64_t y = lo[1]; y <= hi[1]; ++y) {
      const double gy = gap(1, c[1], y), ry = rx - gy * gy;
      if (ry < 0) continue;
      const double dz = std::sqrt(ry);
      const auto z0 = static_cast<uint32_t>(ClampedCell(c[2] - dz, 2));
      const auto z1 = static_cast<uint32_t>(ClampedCell(c[2] + dz, 2));
      // This column's occupied cells from z0 to z1 are one run of entries.
      const size_t column = static_cast<size_t>(x * cells_[1] + y);
      uint32_t first = column_start_[column];
      const uint32_t last = column_start_[column + 1];
      if (last - first > 8) {
        first = static_cast<uint32_t>(
            std::lower_bound(cell_z_.begin() + first, cell_z_.begin() + last, z0) -
            cell_z_.begin());
      } else {
        while (first < last && cell_z_[first] < z0) ++first;
      }
      uint32_t end = first;
      while (end < last && cell_z_[end] <= z1) ++end;
      if (end == first) continue;
      runs.run[runs.count++] = {cell_start_[first], cell_start_[end]};
      runs.candidates += cell_start_[end] - cell_start_[first];
    }
  }
  return true;
}

bool CellGrid::AffordOverflow(size_t candidates) const {
  if (fallback_->ready.load(std::memory_order_acquire) != nullptr) return false;  // built already
  const uint64_t before = fallback_->overflow_read.fetch_add(candidates);
  return before + candidates <= OverflowAllowance();
}

const EntryTree* CellGrid::Tree() const {
  if (const EntryTree* tree = fallback_->ready.load(std::memory_order_acquire)) return tree;
  std::lock_guard<std::mutex> lock(fallback_->mutex);
  if (!fallback_->tree) {
    static const CancelToken never;  // a query outside any loop: the build is O(n log n) anyway
    const CancelToken* cancel = running_loop_token != nullptr ? running_loop_token : &never;
    absl::StatusOr<std::unique_ptr<EntryTree>> tree = EntryTree::Build(entries_, id_, *cancel);
    if (!tree.ok()) return nullptr;
    fallback_->tree = *std::move(tree);
    fallback_->ready.store(fallback_->tree.get(), std::memory_order_release);
  }
  return fallback_->tree.get();
}

namespace {

// A key's parts: (squared distance bits << 32 | point index).
float KeyDistance(uint64_t key) { return std::bit_cast<float>(static_cast<uint32_t>(key >> 32)); }
uint32_t KeyIndex(uint64_t key) { return static_cast<uint32_t>(key); }

}  // namespace

size_t CellGrid::Ball(const float q[3], const NearestQuery& query, float radius, RadiusMatches& out,
                      size_t sample_over, double* step) const {
  out.clear();
  const bool capped = query.count != SIZE_MAX;
  Runs runs;
  const bool fits = CollectRuns(q, radius, runs);
  const auto match = [](uint32_t id, float d2) { return std::pair<uint32_t, float>(id, d2); };
  bool sample = fits && runs.candidates > sample_over;
  const double lattice = sample ? double(runs.candidates) / double(sample_over) : 1.0;
  if (sample) {
    for (size_t r = 0; r < runs.count; ++r) {
      candidates_examined_by_this_thread +=
          AppendLattice(q, runs.run[r].first, runs.run[r].second, lattice, query.limit_sq,
                        query.exclude, out, match);
    }
    // A lattice too thin for a fit (a ball holding far fewer points than the caller expected: a
    // line, an edge) gives way to the whole ball; judged before any flag leaves a point out, so
    // the same ball is sampled whatever was removed since.
    if (4 * out.size() < sample_over) {
      out.clear();
      sample = false;
    }
  }
  if (step != nullptr) *step = sample ? lattice : 1.0;
  if (!sample) {
    if (!fits || (runs.candidates > GridBudget(capped ? query.count : 0) &&
                  !AffordOverflow(runs.candidates))) {
      return TreeBall(q, query, out);
    }
    candidates_examined_by_this_thread += runs.candidates;
    for (size_t r = 0; r < runs.count; ++r) {
      AppendInside(q, runs.run[r].first, runs.run[r].second, query.limit_sq, query.exclude, out,
                   match);
    }
  }
  if (query.flags != nullptr) {
    std::erase_if(out, [&](const auto& m) { return (query.flags[m.first] & query.skip) != 0; });
  }
  if (out.size() <= query.count) return 0;
  std::nth_element(out.begin(), out.begin() + (query.count - 1), out.end(),
                   [](const auto& a, const auto& b) {
                     return a.second < b.second || (a.second == b.second && a.first < b.first);
                   });
  const size_t left_out = out.size() - query.count;
  out.resize(query.count);
  return left_out;
}

size_t CellGrid::TreeBall(const float q[3], const NearestQuery& query, RadiusMatches& out) const {
  const bool capped = query.count != SIZE_MAX;
  const EntryTree* tree = Tree();
  if (tree == nullptr) return 0;  // cancelled: the caller's loop stops at its next check
  // One more than the count tells whether the count left any out.
  NearestQuery asked = query;
  if (capped) ++asked.count;
  std::vector<uint64_t> keys;
  tree->Nearest(q, asked, keys);
  size_t left_out = 0;
  if (capped && keys.size() == asked.count) {
    std::pop_heap(keys.begin(), keys.end());  // the farthest, past the count
    keys.pop_back();
    left_out = 1;
  }
  out.reserve(keys.size());
  for (const uint64_t key : keys) out.emplace_back(KeyIndex(key), KeyDistance(key));
  return left_out;
}

size_t CellGrid::Knn(const float q[3], size_t k, uint32_t exclude, float guess, uint32_t* idx,
                     float* dist_sq, std::vector<uint64_t>& scratch, size_t budget) const {
  const size_t available = entries_.size() - (exclude < entries_.size() ? 1 : 0);
  k = std::min(k, available);
  if (k == 0) return 0;
  // Candidates as (squared distance bits, index): non-negative floats order like their bits,
  // so one integer sort ranks by distance with ties to the lower index.
  float radius = guess > 0 && std::isfinite(guess) ? guess : cell_edge();
  if (budget == 0) budget = GridBudget(k);
  bool gridded = true, restarted = false;
  Runs runs;
  while (true) {
    const bool fits = CollectRuns(q, radius, runs);
    if (!fits || runs.candidates > budget) {
      // A guess far too wide (the previous query's, an isolated point's d_k) starts over from
      // one cell before the tree is asked.
      if (radius > cell_edge() && !restarted) {
        radius = cell_edge();
        restarted = true;
        continue;
      }
      if (!fits || !AffordOverflow(runs.candidates)) {
        gridded = false;
        break;
      }
    }
    // Each widening reads its ball again: the budget is for all of them together.
    budget -= std::min(budget, runs.candidates);
    candidates_examined_by_this_thread += runs.candidates;
    scratch.clear();
    const float r2 = radius * radius;
    for (size_t r = 0; r < runs.count; ++r) {
      AppendInside(
          q, runs.run[r].first, runs.run[r].second, r2, exclude, scratch,
          [](uint32_t id, float d2) { return uint64_t(std::bit_cast<uint32_t>(d2)) << 32 | id; });
    }
    // All points within `radius` are in scratch; if there are k, they hold the k nearest.
    if (scratch.size() >= k) break;
    radius *= 2;
  }
  if (!gridded) {
    const EntryTree* tree = Tree();
    if (tree == nullptr) {  // cancelled: a filler result the caller's loop discards
      std::fill_n(idx, k, id_[0]);
      std::fill_n(dist_sq, k, HUGE_VALF);
      return k;
    }
    tree->Nearest(q, {.limit_sq = HUGE_VALF, .count = k, .exclude = exclude}, scratch);
  }
  if (scratch.size() > k)
    std::nth_element(scratch.begin(), scratch.begin() + (k - 1), scratch.end());
  std::sort(scratch.begin(), scratch.begin() + k);
  for (size_t m = 0; m < k; ++m) {
    idx[m] = KeyIndex(scratch[m]);
    dist_sq[m] = KeyDistance(scratch[m]);
  }
  return k;
}

}  // namespace scanprep
