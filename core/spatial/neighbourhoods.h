// SPDX-License-Identifier: Apache-2.0
// Neighbourhoods computed once per job and shared by every stage (paper §2.1, docs/algorithms.md
// §1-§4): the spatial index (a uniform grid), the k-nearest-neighbour graph, the global radius
// and density, and the minimum radius from the scanline spacing.
#pragma once

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <iterator>
#include <memory>
#include <span>
#include <vector>

#include "absl/status/statusor.h"
#include "core/base/cancel.h"
#include "core/base/point_cloud.h"
#include "core/spatial/cell_grid.h"

namespace scanprep {

// The graph degree unless a job says otherwise (the neighbourhoods stage declares it as the
// default of neighbourhoods.k).
inline constexpr uint32_t kDefaultNeighbourK = 20;

struct NeighbourhoodOptions {
  uint32_t k = kDefaultNeighbourK;  // graph degree, also k_g for the global radius
  // r_min of Eq. (2) per scan, indexed like cloud.scans (a mixed job's finer sensor gets its own
  // smaller one); missing entries and 0 = no lower bound.
  std::vector<double> min_radius;
  // The caller holds each r_min to the data's own scale itself (the neighbourhoods stage, with
  // the scans' measured scanline gaps): Build's backstop at kMaxRadiusPerGlobalRadius·r_g is not
  // applied.
  bool min_radius_held = false;
};

// The minimum radius is capped at this multiple of the global radius r_g.
inline constexpr double kMaxRadiusPerGlobalRadius = 5.0;
// A ball keeps at most this many times k points, the nearest: on a surface a ball of
// kMaxRadiusPerGlobalRadius·r_g holds about 25·k, and the per-scan widening of normals in an
// overlap up to about twice that; beyond it lie only radii far off the data's scale (a unit slip,
// an override) and clusters far denser than the rest. It bounds every stage at O(n·k) work.
inline constexpr uint32_t kMaxBallPointsPerK = 32;

// A ball of the default cap whose radius is at least this many times d_k(i) is stood in for by
// i's k-NN list (Neighbourhoods::Within), without a query: on an even surface it would hold 64·k
// points, twice the cap, so it would be capped anyway (a larger cap c, simplification's for a wide
// r_s, moves the radius out by √(c / 32·k), to twice that cap), and i sits in a spot far denser
// than the radius the stage derived (from the scan's metadata or the cloud's r_g) was meant for: a
// glint, a cluster between the duplicate collapse's u/100 and u. Its k nearest stand for the ball,
// and the work of such a point stays of the order of its k-NN list at any local density (issue 38):
// a 25 % glint costs 1.3× the ordinary job instead of 8.6× (docs/hostile-inputs.md). Ordinary
// balls stay below it: every radius a stage derives is held to a few r_g, and d_k is about r_g
// outside dense spots; on the metrology bench and on tools/hash-outputs.sh's ten jobs (the real
// scans, the default, `paper`, LoOP with Mitra radii) no result changes.
inline constexpr float kStandInRadiusPerDk = 8.f;
// ... and only where i's k nearest lie closer than the cloud's own: d_k(i) at most this times
// r_g. A radius 8·d_k beyond a d_k of the cloud's typical size is not a dense spot but points
// far closer along a scanline than across it (a laser line with profiles 100 point spacings
// apart, r_min reaching the next profile): there the k-NN list is one line, and the capped ball
// of the radius is what spans the profiles.
inline constexpr float kStandInMostDkPerGlobalRadius = 0.5f;

// A sampled ball (Neighbourhoods::Sample) keeps about this many points per point of the k-NN list
// and its centre: 63 at k = 20, what a normals ball of the default r_p holds on a scan at the
// density its radii were meant for (docs/benchmarks.md), where balls stay whole; a denser scan's
// fits see as many points as that one's, and an overlap's own-scan share keeps about k.
inline constexpr uint32_t kSamplePointsPerNeighbour = 3;

// Where scans overlap, a ball of one scan's points is widened once so that it holds about k + 1
// of them, as r_p = d_k would on that scan alone: by √((k+1)/own) for `own` found, at most 2×
// (4× the area; a point with hardly any of its own scan around it is judged on what is there,
// not on a ball reaching into hundreds of another scan's points).
inline float OwnScanWidening(size_t own, uint32_t k) {
  const float wanted =
      std::sqrt(static_cast<float>(k + 1) / static_cast<float>(std::max<size_t>(own, 1)));
  return std::min(2.f, wanted);
}

// The k nearest other points of one point, nearest first: a view of the compact graph that
// decodes a neighbour when asked (Neighbourhoods::knn).
class KnnList {
 public:
  class Iterator {
   public:
    using iterator_category = std::forward_iterator_tag;
    using value_type = uint32_t;
    using difference_type = std::ptrdiff_t;
    using pointer = void;
    using reference = uint32_t;
    Iterator() = default;
    uint32_t operator*() const { return (*list_)[m_]; }
    Iterator& operator++() {
      ++m_;
      return *this;
    }
    Iterator operator++(int) { return {list_, m_++}; }
    bool operator==(const Iterator& other) const { return m_ == other.m_; }

   private:
    friend class KnnList;
    Iterator(const KnnList* list, uint32_t m) : list_(list), m_(m) {}
    const KnnList* list_ = nullptr;
    uint32_t m_ = 0;
  };
  uint32_t operator[](size_t m) const { return wide_ ? wide_[m] : order_[base_ + delta_[m]]; }
  // Distance from the list's point to its m-th neighbour, from the current coordinates. Not
  // stored: at k = 20 the distances would double the graph's memory, and recomputing one is three
  // subtractions.
  float dist(const PointCloud& cloud, size_t m) const {
    return std::sqrt(cloud.squared_distance(point_, (*this)[m]));
  }
  size_t size() const { return k_; }
  Iterator begin() const { return {this, 0}; }
  Iterator end() const { return {this, k_}; }

 private:
  friend class Neighbourhoods;
  const int16_t* delta_ = nullptr;
  const uint32_t* order_ = nullptr;
  const uint32_t* wide_ = nullptr;
  uint32_t base_ = 0, k_ = 0;
  size_t point_ = 0;
};

class Neighbourhoods {
 public:
  // Builds the grid and the k-NN graph over all points of `cloud` (removed ones included: the
  // graph is built once, stages skip removed neighbours). The cloud must outlive this object and
  // its coordinates must not move while it is in use.
  static absl::StatusOr<std::unique_ptr<Neighbourhoods>> Build(const PointCloud& cloud,
                                                               const NeighbourhoodOptions& options,
                                                               const CancelToken& cancel);

  const CellGrid& grid() const { return grid_; }
  // Every point index once, in grid order. A loop that asks a ball per point runs in this order
  // so that consecutive balls read the same cells from cache (the order changes when points move).
  std::span<const uint32_t> order() const { return grid_.order(); }
  uint32_t k() const { return k_; }
  // The k nearest other points of i, nearest first.
  KnnList knn(size_t i) const;
  // Distance from i to knn(i)[m] (KnnList::dist: a caller that holds the list asks it).
  float knn_dist(const PointCloud& cloud, size_t i, uint32_t m) const {
    return knn(i).dist(cloud, m);
  }
  // Points whose list did not fit 16-bit differences (kept as 32-bit indices).
  size_t wide_lists() const { return wide_of_.size(); }
  // d_k(i): distance to the k-th nearest other point.
  float dk(size_t i) const { return k_ ? dk_[i] : 0.f; }

  // r_g: the median d_k over a seeded 1 % sample (at least min(n, 500) points), or half its
  // upper quartile where that is larger (a dense spot holding up to half the points).
  double global_radius() const { return global_radius_; }
  // ρ_g = k / (π r_g²), points per mm² assuming a locally planar surface.
  double density() const { return density_; }
  // r_min of scan s as used: the requested one, capped at kMaxRadiusPerGlobalRadius·r_g.
  double scan_min_radius(size_t s) const { return s < min_radius_.size() ? min_radius_[s] : 0; }
  // r_min of point i's scan.
  float min_radius(size_t i) const {
    return static_cast<float>(scan_min_radius(scan_.empty() ? 0 : scan_[i]));
  }
  // r_p = max(r_min, d_k(p)): the adaptive radius used by normals and smoothing.
  float adaptive_radius(size_t i) const { return std::max(min_radius(i), dk(i)); }

  // Unremoved points within `radius` of point i (i itself included), as (index, squared
  // distance), at most `cap` of them (0: max_ball_points()): a fuller ball keeps its nearest
  // (ties to the lower index) and is counted in capped_balls(). Answers from the k-NN list when
  // the radius fits inside it and no point has moved since the build, else asks the grid.
  // A ball whose radius would hold twice `cap` on an even surface (kStandInRadiusPerDk·d_k(i) or
  // more at the default cap: a dense spot) is answered by i's k-NN list, without a query (O(k) at
  // any density), and counted as capped. `skip`: the removal flags that leave a point out
  // (smoothing still fits to the points merging took out). Returns false when the ball was capped
  // or stood in for: it may miss points within `radius`.
  bool Within(const PointCloud& cloud, size_t i, float radius, RadiusMatches& out,
              uint8_t skip = kRemovedMask, size_t cap = 0) const;
  uint32_t max_ball_points() const { return std::max<uint32_t>(kMaxBallPointsPerK * k_, 64); }
  // Within for a fit or a mean (a plane, a normal, a weighted average, a mean quality), which
  // needs an even spread of the ball, not every point of it. A ball that would hold more than
  // 2·sample_points() points on a surface of i's d_k is read as a lattice of that many of its
  // cells' entries (CellGrid::Ball's sample_over), and those inside stand for it, about
  // sample_points() of them, i itself first unless `skip` leaves it out; counted in
  // sampled_balls(). A lattice holding fewer than a quarter of what it read (a ball far thinner
  // than its d_k said: a line, an edge; judged before `skip`, so a ball stays sampled or whole
  // as points are removed) gives way to the whole ball. The work of a fit then stays of the order
  // of the k-NN list however densely the surface is sampled (issue 38): a radius that holds the
  // stated uncertainty u keeps its size in mm as the spacing shrinks, and without this a scan 16×
  // as dense reads 2-3× the points per ball.
  bool Sample(const PointCloud& cloud, size_t i, float radius, RadiusMatches& out,
              uint8_t skip = kRemovedMask) const;
  size_t sample_points() const { return size_t{kSamplePointsPerNeighbour} * (k_ + 1); }
  // Balls capped so far, and the points they left out; balls sampled.
  uint64_t capped_balls() const { return capped_balls_.load(std::memory_order_relaxed); }
  uint64_t capped_points() const { return capped_points_.load(std::memory_order_relaxed); }
  uint64_t sampled_balls() const { return sampled_balls_.load(std::memory_order_relaxed); }

  // The points moved by at most `max_shift` each (smoothing bounds it by δ, Eq. 10). Instead of
  // a rebuild of the graph (a full k-NN pass) every k-NN list is re-ranked by its new distances,
  // so knn() stays nearest first and dk() follows the points; the grid is re-sorted on the new
  // positions, so Within() stays exact. The lists may now miss a point that moved into the k
  // nearest from outside (at 1 M points a smoothing move is half the spacing), so Within() stops
  // answering from them.
  absl::Status PointsMoved(const PointCloud& cloud, float max_shift, const CancelToken& cancel);

 private:
  Neighbourhoods() = default;
  void ComputeGlobalRadius();
  // Within, with the grid's sample_over (SIZE_MAX: the whole ball).
  bool Query(const PointCloud& cloud, size_t i, float radius, RadiusMatches& out, uint8_t skip,
             size_t cap, size_t sample_over) const;
  // Stores idx (k indices) as i's list of rank differences; false, with the list marked wide,
  // when one does not fit 16 bits.
  bool Encode(size_t i, const uint32_t* idx);
  // Where i's wide list starts in wide_.
  size_t WideStart(size_t i) const;
  CellGrid grid_;
  uint32_t k_ = 0;
  // The graph, compact: the points are ranked in the grid order of the build, and a neighbour is
  // kept as the 16-bit difference of its rank from the point's (neighbours are near in that
  // order: within a couple of the grid's x-slabs), 2 bytes instead of 4, 44 bytes a point at
  // k = 20 with the rank table instead of 80 (48 once the points moved: the order, which the
  // grid held until then, is kept beside it). A list with a difference beyond 16 bits (a
  // grid with huge slabs, a far point's neighbours) starts with kWideList and lives in wide_.
  static constexpr int16_t kWideList = INT16_MIN;
  std::vector<int16_t> delta_;     // k per point
  std::vector<uint32_t> rank_;     // point -> rank
  std::vector<uint32_t> by_rank_;  // rank -> point, once the points moved (grid_.order() before)
  std::vector<uint32_t> wide_;     // k per wide list
  // (point, the number of its list in wide_), sorted by point.
  std::vector<std::pair<uint32_t, uint32_t>> wide_of_;
  std::vector<float> dk_;
  double global_radius_ = 0, density_ = 0;
  std::vector<double> min_radius_;  // per scan
  std::span<const uint32_t> scan_;  // the cloud's scan index per point
  bool moved_ = false;              // points moved since the graph was built
  mutable std::atomic<uint64_t> capped_balls_{0}, capped_points_{0}, sampled_balls_{0};
};

// Eq. (2): r_min = √3·Δs + ε_u (the circumsphere of a cube of edge 2Δs, which reaches both
// neighbouring scanlines, plus a margin for measurement uncertainty).
double MinRadiusFromScanlineSpacing(double scanline_spacing, double epsilon_u);

}  // namespace scanprep
