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
// Exact: a ball returns precisely the points whose squared distance, computed as nanoflann does
// it (((q−p)ₓ² + (q−p)ᵧ²) + (q−p)_z² in float), is below r², so its sets equal the kd-tree's.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <span>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "core/pipeline/cancel.h"
#include "core/point_cloud.h"

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

  // How many points a ball query of this radius reads (its candidates): the work counter that
  // tests hold to a bound where a degenerate grid would read most of the cloud.
  size_t Candidates(const float q[3], float radius) const {
    size_t read = 0;
    if (!ForEachRun(q, radius, [&](uint32_t begin, uint32_t end) { read += end - begin; })) {
      read = entries_.size();
    }
    return read;
  }

  // Every point j with squared distance d2 < radius² to q, as (j, d2), unsorted, into `out`.
  void Within(const float q[3], float radius, RadiusMatches& out) const;

  // The k nearest points to q other than `exclude`, nearest first (ties: lower index first), as
  // indices and squared distances; returns how many were found (< k only if the cloud has fewer).
  // `guess` is a radius to try first; `scratch` is reused between calls.
  size_t Knn(const float q[3], size_t k, uint32_t exclude, float guess, uint32_t* idx,
             float* dist_sq, std::vector<uint64_t>& scratch) const;

 private:
  // A point's coordinates, copied next to their cell's: a ball reads them in runs. Its index is
  // id_[e], not a fourth field: order() needs the indices as one array anyway.
  struct Entry {
    float x, y, z;
  };
  // Calls run(begin, end) for each run of entries in cells that may hold a point within
  // `radius` of q; false when the cell range is wider than the cell list, so a scan of all
  // entries is cheaper.
  template <typename Run>
  bool ForEachRun(const float q[3], float radius, Run&& run) const;
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
};

template <typename Run>
bool CellGrid::ForEachRun(const float q[3], float radius, Run&& run) const {
  if (entries_.empty()) return true;
  // Padded so that float rounding in the caller's distance test cannot admit a point the cell
  // range missed; the range itself is computed in double.
  const double r = double(radius) * (1 + 1e-5) + 1e-30;
  if (!(r * inverse_edge_ < 1e12)) return false;
  int64_t lo[3], hi[3];
  double c[3];
  const double reach = r * inverse_edge_;
  for (int a = 0; a < 3; ++a) {
    // Clamped like the points' own cells: the outermost cells hold what lies beyond the box.
    c[a] = CellOf(q[a], a);
    lo[a] = ClampedCell(c[a] - reach, a);
    hi[a] = ClampedCell(c[a] + reach, a);
  }
  const double span =
      double(hi[0] - lo[0] + 1) * double(hi[1] - lo[1] + 1) * double(hi[2] - lo[2] + 1);
  if (span > double(cell_start_.size()) + double(column_start_.size())) return false;
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
      if (end > first) run(cell_start_[first], cell_start_[end]);
    }
  }
  return true;
}

inline void CellGrid::Within(const float q[3], float radius, RadiusMatches& out) const {
  out.clear();
  const float r2 = radius * radius;
  auto scan = [&](uint32_t begin, uint32_t end) {
    AppendInside(q, begin, end, r2, UINT32_MAX, out,
                 [](uint32_t id, float d2) { return std::pair<uint32_t, float>(id, d2); });
  };
  if (!ForEachRun(q, radius, scan)) scan(0, static_cast<uint32_t>(entries_.size()));
}

}  // namespace scanprep
