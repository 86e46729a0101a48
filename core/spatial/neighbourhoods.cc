// SPDX-License-Identifier: Apache-2.0
#include "core/spatial/neighbourhoods.h"

#include <algorithm>
#include <cmath>
#include <mutex>
#include <numbers>
#include <random>

#include "core/base/parallel.h"
#include "core/base/status_macros.h"

namespace scanprep {

double MinRadiusFromScanlineSpacing(double scanline_spacing, double epsilon_u) {
  return std::sqrt(3.0) * scanline_spacing + epsilon_u;
}

namespace {

// Cell edge of the grid in units of the typical d_k. The stages' balls are r_p ≈ 1.8·d_k (r_min)
// and the graph's k-NN balls d_k: cells of 2·d_k read a few more candidates per ball than cells
// of d_k but a quarter of the columns. Measured on the benchmark cloud (1 M / 4 M points, 2
// threads, whole pipeline): 1.0·d_k 5.61 / 40.4 s, 1.5 5.34, 2.0 5.20 / 34.2, 2.5 5.33.
constexpr float kCellEdgePerDk = 2.0f;

// The typical value of a sample of d_k (reordered): its median, unless a quarter of the sample
// lies more than twice as far apart, then half that upper quartile. A dense spot holding up to
// half the points would otherwise set the data's scale: the grid's cells and r_g sized for the
// spot, every radius held to a few of its r_g, and every ball on the rest of the surface crossing
// hundreds of columns (27× the work per point at a 50 % glint). On a surface, overlaps included,
// the upper quartile is within 1.5× the median, and the median stands.
float TypicalDk(std::vector<float>& d) {
  if (d.empty()) return 0.f;
  std::nth_element(d.begin(), d.begin() + d.size() / 2, d.end());
  const float median = d[d.size() / 2];
  std::nth_element(d.begin(), d.begin() + 3 * d.size() / 4, d.end());
  return std::max(median, d[3 * d.size() / 4] / 2);
}

// The typical d_k of an evenly strided sample, from a grid of any cell size. The first grid's
// cells are sized as if the points filled its box, so on a surface they hold hundreds: each of
// the 1,000 queries may read n/64 candidates (16·n in all, one k-NN pass's worth) before the
// grid builds its kd-tree for them (a quarter second at 1 M points, for nothing on a scan).
float SampleDk(const PointCloud& cloud, const CellGrid& grid, uint32_t k) {
  const size_t n = cloud.size();
  const size_t sample = std::min<size_t>(n, 1000);
  const size_t budget = std::max(CellGrid::GridBudget(k), n / 64);
  std::vector<float> dk(sample);
  std::vector<uint32_t> idx(k);
  std::vector<float> d2(k);
  std::vector<uint64_t> scratch;
  for (size_t s = 0; s < sample; ++s) {
    const size_t i = s * n / sample;
    const float q[3] = {cloud.x[i], cloud.y[i], cloud.z[i]};
    const size_t found =
        grid.Knn(q, k, static_cast<uint32_t>(i), 0.f, idx.data(), d2.data(), scratch, budget);
    dk[s] = found ? std::sqrt(d2[found - 1]) : 0.f;
  }
  return TypicalDk(dk);
}

// entries[m] = the old entries[slot[m]] for the k = slot.size() entries of one list.
template <typename T>
void PermuteList(T* entries, const std::vector<uint32_t>& slot, std::vector<T>& old) {
  old.assign(entries, entries + slot.size());
  for (size_t m = 0; m < slot.size(); ++m) entries[m] = old[slot[m]];
}

}  // namespace

absl::StatusOr<std::unique_ptr<Neighbourhoods>> Neighbourhoods::Build(
    const PointCloud& cloud, const NeighbourhoodOptions& options, const CancelToken& cancel) {
  std::unique_ptr<Neighbourhoods> nb(new Neighbourhoods());
  const size_t n = cloud.size();
  nb->k_ = static_cast<uint32_t>(std::min<size_t>(options.k, n > 0 ? n - 1 : 0));
  nb->min_radius_ = options.min_radius;
  nb->scan_ = cloud.scan;
  const uint32_t k = nb->k_;
  SCANPREP_RETURN_IF_ERROR(nb->grid_.Build(cloud, 0.f, cancel));
  if (k == 0) return nb;
  const float typical_dk = SampleDk(cloud, nb->grid_, k);
  if (typical_dk > 0) {
    SCANPREP_RETURN_IF_ERROR(nb->grid_.Build(cloud, kCellEdgePerDk * typical_dk, cancel));
  }
  nb->dk_.resize(n);
  nb->delta_.resize(n * k);
  const std::span<const uint32_t> order = nb->grid_.order();
  nb->rank_.resize(n);
  for (size_t v = 0; v < n; ++v) nb->rank_[order[v]] = static_cast<uint32_t>(v);

  // In grid order, so consecutive queries read the same cells, and each starts from a radius
  // just above its predecessor's d_k.
  // Lists that need 32-bit indices go to wide_, a block's at once; where they lie there depends
  // on the threads' timing, which list is found for a point does not (wide_of_ is sorted).
  std::mutex wide_mutex;
  SCANPREP_RETURN_IF_ERROR(ParallelFor(n, cancel, [&](size_t begin, size_t end) {
    std::vector<uint32_t> idx(k);
    std::vector<float> d2(k);
    std::vector<uint64_t> scratch;
    std::vector<uint32_t> wide_points, wide_lists;
    float guess = typical_dk;
    for (size_t v = begin; v < end; ++v) {
      const uint32_t i = order[v];
      const float q[3] = {cloud.x[i], cloud.y[i], cloud.z[i]};
      nb->grid_.Knn(q, k, i, guess * 1.2f, idx.data(), d2.data(), scratch);
      nb->dk_[i] = std::sqrt(d2[k - 1]);
      guess = nb->dk_[i];
      if (nb->Encode(i, idx.data())) continue;
      wide_points.push_back(i);
      wide_lists.insert(wide_lists.end(), idx.begin(), idx.end());
    }
    if (wide_points.empty()) return;
    std::lock_guard<std::mutex> lock(wide_mutex);
    for (size_t w = 0; w < wide_points.size(); ++w) {
      nb->wide_of_.emplace_back(wide_points[w], static_cast<uint32_t>(nb->wide_.size() / k + w));
    }
    nb->wide_.insert(nb->wide_.end(), wide_lists.begin(), wide_lists.end());
  }));
  std::sort(nb->wide_of_.begin(), nb->wide_of_.end());

  nb->ComputeGlobalRadius();
  // r_g only sets defaults, r_max = 5·r_g among them (docs/algorithms.md §2). A minimum radius far
  // beyond it — a scanline spacing stated in the wrong unit, or a cluster of coincident points
  // with d_k = 0 — would make every ball hold most of the cloud and each stage quadratic.
  if (!options.min_radius_held) {
    for (double& r : nb->min_radius_)
      r = std::min(r, kMaxRadiusPerGlobalRadius * nb->global_radius_);
  }
  return nb;
}

// r_g from a seeded 1 % sample (at least min(n, 500) points): the paper's cheap global scale.
void Neighbourhoods::ComputeGlobalRadius() {
  const size_t n = dk_.size();
  const size_t sample = std::min(n, std::max<size_t>((n + 99) / 100, 500));
  std::vector<float> d(sample);
  std::mt19937_64 rng(0x5ca9);
  std::uniform_int_distribution<size_t> pick(0, n - 1);
  for (size_t s = 0; s < sample; ++s) d[s] = dk(sample == n ? s : pick(rng));
  global_radius_ = TypicalDk(d);
  density_ = global_radius_ > 0 ? k_ / (std::numbers::pi * global_radius_ * global_radius_) : 0.0;
}

absl::Status Neighbourhoods::PointsMoved(const PointCloud& cloud, float max_shift,
                                         const CancelToken& cancel) {
  if (max_shift == 0) return absl::OkStatus();
  moved_ = true;
  // The ranks stay those of the build's grid order, which the rebuild replaces: kept from here.
  if (k_ > 0 && by_rank_.empty()) by_rank_.assign(grid_.order().begin(), grid_.order().end());
  SCANPREP_RETURN_IF_ERROR(grid_.Build(cloud, grid_.cell_edge(), cancel));
  if (k_ == 0) return absl::OkStatus();
  SCANPREP_RETURN_IF_ERROR(ParallelFor(cloud.size(), cancel, [&](size_t begin, size_t end) {
    std::vector<float> d2(k_);
    std::vector<uint32_t> slot(k_);
    std::vector<int16_t> deltas;
    std::vector<uint32_t> wide;
    for (size_t i = begin; i < end; ++i) {
      const KnnList list = knn(i);
      // Insertion sort of the list's slots by squared distance: small moves leave the list
      // nearly ordered.
      for (uint32_t m = 0; m < k_; ++m) {
        const float d = cloud.squared_distance(i, list[m]);
        uint32_t at = m;
        for (; at > 0 && d2[at - 1] > d; --at) {
          slot[at] = slot[at - 1];
          d2[at] = d2[at - 1];
        }
        slot[at] = m;
        d2[at] = d;
      }
      // The same neighbours re-ordered: the stored entries are permuted in place, so no
      // neighbour's rank is looked up again (a random read each) and every list keeps its form.
      if (list.wide_ != nullptr) {
        PermuteList(&wide_[WideStart(i)], slot, wide);
      } else {
        PermuteList(&delta_[i * k_], slot, deltas);
      }
      dk_[i] = std::sqrt(d2[k_ - 1]);
    }
  }));
  ComputeGlobalRadius();
  return absl::OkStatus();
}

KnnList Neighbourhoods::knn(size_t i) const {
  KnnList list;
  list.k_ = k_;
  list.point_ = i;
  if (k_ == 0) return list;
  if (delta_[i * k_] == kWideList) {
    list.wide_ = &wide_[WideStart(i)];
    return list;
  }
  list.delta_ = &delta_[i * k_];
  list.order_ = by_rank_.empty() ? grid_.order().data() : by_rank_.data();
  list.base_ = rank_[i];
  return list;
}

size_t Neighbourhoods::WideStart(size_t i) const {
  const auto at = std::lower_bound(wide_of_.begin(), wide_of_.end(),
                                   std::pair<uint32_t, uint32_t>(static_cast<uint32_t>(i), 0));
  return size_t{at->second} * k_;
}

bool Neighbourhoods::Encode(size_t i, const uint32_t* idx) {
  int16_t* out = &delta_[i * k_];
  const int64_t base = rank_[i];
  for (uint32_t m = 0; m < k_; ++m) {
    const int64_t delta = int64_t{rank_[idx[m]]} - base;
    if (delta <= kWideList || delta > INT16_MAX) {
      out[0] = kWideList;
      return false;
    }
    out[m] = static_cast<int16_t>(delta);
  }
  return true;
}

bool Neighbourhoods::Within(const PointCloud& cloud, size_t i, float radius, RadiusMatches& out,
                            uint8_t skip, size_t cap) const {
  return Query(cloud, i, radius, out, skip, cap, SIZE_MAX);
}

bool Neighbourhoods::Sample(const PointCloud& cloud, size_t i, float radius, RadiusMatches& out,
                            uint8_t skip) const {
  // On a surface a ball holds about (k + 1)·(r / d_k)² points: only one that would hold more
  // than twice the sample is worth a lattice.
  const double per_dk = dk(i) > 0 ? double(radius) / dk(i) : 0.0;
  const bool full = (k_ + 1) * per_dk * per_dk > 2.0 * sample_points();
  return Query(cloud, i, radius, out, skip, 0, full ? 2 * sample_points() : SIZE_MAX);
}

bool Neighbourhoods::Query(const PointCloud& cloud, size_t i, float radius, RadiusMatches& out,
                           uint8_t skip, size_t cap, size_t sample_over) const {
  out.clear();
  if (cap == 0) cap = max_ball_points();
  // Twice the cap on an even surface: r ≥ kStandInRadiusPerDk·d_k·√(cap / max_ball_points()).
  const float per_dk = kStandInRadiusPerDk * dk(i);
  const bool stand_in =
      k_ > 0 && double(radius) * radius * max_ball_points() >= double(per_dk) * per_dk * cap &&
      dk(i) <= kStandInMostDkPerGlobalRadius * global_radius_;
  if (k_ > 0 && ((!moved_ && radius <= dk(i) && cap > k_) || stand_in)) {
    // At most k + 1 points: not capped, unless the list stands in for a far fuller ball.
    auto skipped = [&](size_t j) { return (cloud.flags[j] & skip) != 0; };
    if (!skipped(i)) out.emplace_back(static_cast<uint32_t>(i), 0.f);
    for (const uint32_t j : knn(i)) {
      const float d2 = cloud.squared_distance(i, j);
      if (!(d2 < radius * radius)) break;  // the list is nearest first
      if (!skipped(j)) out.emplace_back(j, d2);
    }
    if (!stand_in) return true;
    capped_balls_.fetch_add(1, std::memory_order_relaxed);
    return false;
  }
  const float q[3] = {cloud.x[i], cloud.y[i], cloud.z[i]};
  const NearestQuery query = {
      .limit_sq = radius * radius, .count = cap, .flags = cloud.flags.data(), .skip = skip};
  double step = 1;
  const size_t left_out = grid_.Ball(q, query, radius, out, sample_over, &step);
  if (step > 1) {
    // The centre belongs to its own fit (weight 1 in Eq. 4 and 6) whether the lattice read it
    // or not; it comes first, as the k-NN path puts it.
    const auto at =
        std::find_if(out.begin(), out.end(), [&](const auto& m) { return m.first == i; });
    if (at != out.end()) {
      std::iter_swap(out.begin(), at);
    } else if ((cloud.flags[i] & skip) == 0) {
      out.emplace_back(static_cast<uint32_t>(i), 0.f);
      std::swap(out.front(), out.back());
    }
    sampled_balls_.fetch_add(1, std::memory_order_relaxed);
  }
  if (left_out == 0) return true;
  capped_balls_.fetch_add(1, std::memory_order_relaxed);
  capped_points_.fetch_add(left_out, std::memory_order_relaxed);
  return false;
}

}  // namespace scanprep
