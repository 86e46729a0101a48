// SPDX-License-Identifier: Apache-2.0
// A uniform grid over the cloud's points, in place of a kd-tree: the points are copied next to
// their indices and sorted by cell, x-major and z-minor, so every (x, y) column of cells is one
// contiguous stretch; a dense table holds where each column's occupied cells start. A ball then
// reads one contiguous run per column it crosses (a dozen or so) instead of descending a tree,
// and the k nearest neighbours come from balls widened until they hold k points.
//
// The grid covers a robust box (percentiles of the coordinates), not the bounding box, so one
// stray point at 1e8 mm cannot make every point share a cell; points beyond the box live in the
// outermost cells, and queries treat those cells as reaching to infinity.
//
// Bounded work on any input: a query reads at most kMaxColumns columns and a budget of
// candidates from the cells (GridBudget); a query that would read more (cells stretched by a far
// part, a cluster of near-identical points in one cell, an isolated point whose neighbours lie
// across thousands of empty columns) is answered by a kd-tree over the same entries
// (entry_tree.h). Building that tree costs about as much as reading the grid's points a few
// times over, so, as one rents before buying, such queries read their cells anyway until they
// have read OverflowAllowance() candidates in all, and only then is the tree built.
//
// Exact: a ball returns precisely the points whose squared distance, computed as nanoflann does
// it (((q−p)ₓ² + (q−p)ᵧ²) + (q−p)_z² in float), is below r², so its sets equal the kd-tree's;
// a capped one and a k-NN list keep the nearest, ties to the lower index, on either path: which
// path answered is never visible in a result.
#pragma once

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <memory>
#include <mutex>
#include <span>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "core/base/cancel.h"
#include "core/base/point_cloud.h"
#include "core/spatial/entry_tree.h"

namespace scanprep {

// Ball-query result: (point index, squared distance).
using RadiusMatches = std::vector<std::pair<uint32_t, float>>;

class CellGrid {
 public:
  // Grids the cloud's current positions with cells of edge `cell_edge` (widened when the robust
  // box would need more than 2^21 cells along an axis, or the column table more than 4 entries a
  // point); 0 = a first guess from the robust box, about 8 points per cell if they filled it.
  absl::Status Build(const PointCloud& cloud, float cell_edge, const CancelToken& cancel);

  float cell_edge() const { return static_cast<float>(edge_); }
  // Bits of the cell keys the points were sorted by: up to 32 the sort uses 32-bit keys.
  int key_bits() const { return key_bits_; }
  // Point indices in cell order: neighbouring entries are near in space.
  std::span<const uint32_t> order() const { return id_; }

  // The most columns a query reads from the grid, and the fewest candidates it may read from
  // their cells (GridBudget). On the benchmark scans (100 k points, default pipeline) 99.95 % of
  // the capped balls read 64-1,023 candidates and none more than 2,047; every uncapped ball and
  // k-NN query fewer than 256; a point off the surface (1 M points) reaches 8 cells (289
  // columns) for its k nearest. A ball in a cluster of thousands of points reads them all to
  // keep its nearest 32·k: the kd-tree finds those reading a few hundred more.
  static constexpr size_t kMaxColumns = 1024;
  static constexpr size_t kMinGridCandidates = 2048;
  // The candidates a query that wants `wanted` points (k, a ball's cap; 0 = all) may read from
  // the grid's cells before the kd-tree answers it instead.
  static size_t GridBudget(size_t wanted) {
    return std::max<size_t>(kMinGridCandidates, 2 * std::min<size_t>(wanted, SIZE_MAX / 2));
  }
  // The candidates queries over their budget may read from the cells in all before the kd-tree
  // is built: four passes over the points (a 1 M-point tree costs about 2·10⁹ instructions to
  // build, reading 4 M candidates about 10⁸). On the benchmark scans 407 of 1 M k-NN queries
  // (points off the surface with dense columns below) read 1.6 M: no tree.
  size_t OverflowAllowance() const { return 4 * entries_.size() + 65536; }
  // Whether a query of this grid has needed the kd-tree yet (for tests and the report).
  bool tree_built() const { return fallback_->ready.load(std::memory_order_acquire) != nullptr; }

  // Every point j with squared distance d2 < radius² to q, as (j, d2), unsorted, into `out`.
  void Within(const float q[3], float radius, RadiusMatches& out) const {
    Ball(q, {.limit_sq = radius * radius, .count = SIZE_MAX}, radius, out);
  }
  // The points `query` asks for (query.limit_sq = radius²), as (j, d2), unsorted, into `out`;
  // returns how many a count left out: exact when the grid answered, 1 (at least one) when the
  // tree did, which stops at the count.
  // `sample_over`: where the ball's cells hold more candidates than this, only an even lattice
  // of about that many entries is read, every (candidates / sample_over)-th of each column's run
  // (entries are in cell order, so each cell gives its share), and those inside are returned: a
  // spatially even subset of the ball for a fit or a mean, read at a cost that does not grow with
  // the density. The lattice is the same for every query at one step; one holding fewer than a
  // quarter of sample_over (a line, an edge) gives way to the whole ball. A ball crossing more than
  // kMaxColumns columns is answered by the tree, whole up to the count. `step`, when given, is
  // set to the lattice's step (1: the whole ball was read).
  size_t Ball(const float q[3], const NearestQuery& query, float radius, RadiusMatches& out,
              size_t sample_over = SIZE_MAX, double* step = nullptr) const;

  // The k nearest points to q other than `exclude`, nearest first (ties: lower index first;
  // which of those tied at the k-th distance are in: see above), as
  // indices and squared distances; returns how many were found (< k only if the cloud has fewer).
  // `guess` is a radius to try first; `scratch` is reused between calls. `budget`: the candidates
  // it may read from the grid before the kd-tree answers instead (0: GridBudget(k)); a caller
  // asking only a fixed number of queries may allow more rather than build the tree for them.
  size_t Knn(const float q[3], size_t k, uint32_t exclude, float guess, uint32_t* idx,
             float* dist_sq, std::vector<uint64_t>& scratch, size_t budget = 0) const;

 private:
  using Entry = GridEntry;
  // The cells' runs of entries a query reads, at most one per column.
  struct Run {
    uint32_t first, second;  // entries [first, second)
  };
  struct Runs {
    Run run[kMaxColumns];  // not zeroed: a query writes only the runs it uses
    size_t count = 0;
    size_t candidates = 0;
  };
  // Collects the runs of entries in cells that may hold a point within `radius` of q, and how
  // many candidates they hold; false when they would cross more than kMaxColumns columns.
  bool CollectRuns(const float q[3], float radius, Runs& runs) const;
  // Appends make(id, d2) for the entries [begin, end) with squared distance d2 < limit and
  // id != exclude. Branch-free: every candidate is written, the end advances only past those
  // kept (about half of them, which a branch would mispredict).
  template <typename T, typename Make>
  void AppendInside(const float q[3], uint32_t begin, uint32_t end, float limit, uint32_t exclude,
                    std::vector<T>& out, Make make) const {
    size_t at = out.size();
    out.resize(at + (end - begin));
    for (uint32_t e = begin; e < end; ++e) {
      const Entry& p = entries_[e];
      const float dx = q[0] - p.x, dy = q[1] - p.y, dz = q[2] - p.z;
      const float d2 = dx * dx + dy * dy + dz * dz;
      out[at] = make(id_[e], d2);
      at += (d2 < limit) & (id_[e] != exclude);
    }
    out.resize(at);
  }
  // AppendInside for the entries at floor(m·step) in [begin, end), integer m: the lattice that
  // Ball's sample reads. Returns how many entries it read.
  template <typename T, typename Make>
  size_t AppendLattice(const float q[3], uint32_t begin, uint32_t end, double step, float limit,
                       uint32_t exclude, std::vector<T>& out, Make make) const {
    size_t read = 0;
    for (double m = std::ceil(begin / step);; m += 1) {
      const auto e = static_cast<uint32_t>(m * step);
      if (e >= end) break;
      if (e < begin) continue;  // rounding of m·step just below begin
      ++read;
      const Entry& p = entries_[e];
      const float dx = q[0] - p.x, dy = q[1] - p.y, dz = q[2] - p.z;
      const float d2 = dx * dx + dy * dy + dz * dz;
      if (d2 < limit && id_[e] != exclude) out.push_back(make(id_[e], d2));
    }
    return read;
  }
  // For a query over its budget: whether the overflow allowance still holds its `candidates`
  // (which are then counted against it) and the tree is not built yet.
  bool AffordOverflow(size_t candidates) const;
  // Ball's answer from the kd-tree (the same points as the grid's whole read).
  size_t TreeBall(const float q[3], const NearestQuery& query, RadiusMatches& out) const;
  // The kd-tree over the entries, built on first use (cancelled with the token of the loop that
  // asks, running_loop_token); null when that token fired first.
  const EntryTree* Tree() const;
  // Sorts the points by cell with keys of type Key (32 or 64 bits) and fills the tables.
  template <typename Key>
  absl::Status Sort(const PointCloud& cloud, int z_bits, int key_bits, const CancelToken& cancel);
  double CellOf(float v, int axis) const { return (double(v) - origin_[axis]) * inverse_edge_; }
  // The cell along `axis` that holds coordinate v: points outside the grid's box belong to its
  // outermost cells.
  int64_t ClampedCell(double cell, int axis) const {
    return static_cast<int64_t>(std::clamp(std::floor(cell), 0.0, double(cells_[axis] - 1)));
  }
  int64_t PointCell(float v, int axis) const { return ClampedCell(CellOf(v, axis), axis); }

  double edge_ = 1, inverse_edge_ = 1;
  int key_bits_ = 0;
  double origin_[3] = {0, 0, 0};
  int64_t cells_[3] = {1, 1, 1};        // grid extent per axis
  std::vector<Entry> entries_;          // sorted by (column x·cells_y + y, z)
  std::vector<uint32_t> id_;            // the point index of entries_[e]
  std::vector<uint32_t> column_start_;  // column c: occupied cells [column_start_[c], [c+1])
  std::vector<uint32_t> cell_z_;        // per occupied cell, in entry order: its z
  std::vector<uint32_t> cell_start_;    // occupied cell c: entries [cell_start_[c], [c+1])
  // The fallback tree, built by the first query that needs it while the others wait.
  struct Fallback {
    std::mutex mutex;
    std::atomic<const EntryTree*> ready{nullptr};
    std::unique_ptr<EntryTree> tree;
    std::atomic<uint64_t> overflow_read{0};  // candidates over-budget queries read from the cells
  };
  std::unique_ptr<Fallback> fallback_ = std::make_unique<Fallback>();
};

}  // namespace scanprep
