#include "core/neighbourhoods.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>

#include "core/parallel.h"

namespace scanprep {

double MinRadiusFromScanlineSpacing(double scanline_spacing, double epsilon_u) {
  return std::sqrt(3.0) * scanline_spacing + epsilon_u;
}

absl::StatusOr<std::unique_ptr<Neighbourhoods>> Neighbourhoods::Build(
    const PointCloud& cloud, const NeighbourhoodOptions& options, const CancelToken& cancel) {
  std::unique_ptr<Neighbourhoods> nb(new Neighbourhoods());
  const size_t n = cloud.size();
  nb->tree_ = std::make_unique<KdTree>(cloud);
  nb->k_ = static_cast<uint32_t>(std::min<size_t>(options.k, n > 0 ? n - 1 : 0));
  nb->min_radius_ = options.min_radius;
  const uint32_t k = nb->k_;
  nb->index_.resize(n * k);
  nb->dist_.resize(n * k);
  if (k == 0) return nb;

  absl::Status status = ParallelFor(n, cancel, [&](size_t begin, size_t end) {
    std::vector<uint32_t> idx(k + 1);
    std::vector<float> d2(k + 1);
    for (size_t i = begin; i < end; ++i) {
      const float q[3] = {cloud.x[i], cloud.y[i], cloud.z[i]};
      const size_t found = nb->tree_->Knn(q, k + 1, idx.data(), d2.data());
      // Drop the query point itself; among exact duplicates it need not come first, and in a
      // cluster of more than k+1 duplicates it may be missing, then the farthest entry goes.
      size_t self = std::find(idx.begin(), idx.begin() + found, static_cast<uint32_t>(i)) -
                    idx.begin();
      if (self == found) self = found - 1;
      size_t out = i * k;
      for (size_t j = 0; j < found && out < (i + 1) * k; ++j) {
        if (j == self) continue;
        nb->index_[out] = idx[j];
        nb->dist_[out] = std::sqrt(d2[j]);
        ++out;
      }
    }
  });
  if (!status.ok()) return status;

  nb->ComputeGlobalRadius();
  // r_g only sets defaults, r_max = 5·r_g among them (algorithms.md §2). A minimum radius far
  // beyond it — a scanline spacing stated in the wrong unit, or a cluster of coincident points
  // with d_k = 0 — would make every ball hold most of the cloud and each stage quadratic.
  nb->min_radius_ = std::min(nb->min_radius_, kMaxRadiusPerGlobalRadius * nb->global_radius_);
  return nb;
}

// r_g from a seeded 1 % sample (at least min(n, 500) points): the paper's cheap global scale.
void Neighbourhoods::ComputeGlobalRadius() {
  const size_t n = index_.size() / k_;
  const size_t sample = std::min(n, std::max<size_t>((n + 99) / 100, 500));
  std::vector<float> d(sample);
  std::mt19937_64 rng(0x5ca9);
  std::uniform_int_distribution<size_t> pick(0, n - 1);
  for (size_t s = 0; s < sample; ++s) d[s] = dk(sample == n ? s : pick(rng));
  std::nth_element(d.begin(), d.begin() + sample / 2, d.end());
  global_radius_ = d[sample / 2];
  density_ = global_radius_ > 0 ? k_ / (std::numbers::pi * global_radius_ * global_radius_) : 0.0;
}

absl::Status Neighbourhoods::PointsMoved(const PointCloud& cloud, float max_shift,
                                         const CancelToken& cancel) {
  slack_ += max_shift;
  if (k_ == 0) return absl::OkStatus();
  absl::Status status = ParallelFor(cloud.size(), cancel, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      uint32_t* idx = &index_[i * k_];
      float* dist = &dist_[i * k_];
      const Eigen::Vector3f p = cloud.point(i);
      // Insertion sort: small moves leave the list nearly ordered.
      for (uint32_t m = 0; m < k_; ++m) {
        const uint32_t j = idx[m];
        const float d = (cloud.point(j) - p).norm();
        uint32_t at = m;
        for (; at > 0 && dist[at - 1] > d; --at) {
          idx[at] = idx[at - 1];
          dist[at] = dist[at - 1];
        }
        idx[at] = j;
        dist[at] = d;
      }
    }
  });
  if (!status.ok()) return status;
  ComputeGlobalRadius();
  return absl::OkStatus();
}

void Neighbourhoods::Within(const PointCloud& cloud, size_t i, float radius,
                            RadiusMatches& out) const {
  out.clear();
  if (k_ > 0 && slack_ == 0 && radius <= dk(i)) {
    if (!cloud.removed(i)) out.emplace_back(static_cast<uint32_t>(i), 0.f);
    const auto idx = knn(i);
    const auto dist = knn_dist(i);
    for (uint32_t j = 0; j < k_ && dist[j] < radius; ++j) {
      if (!cloud.removed(idx[j])) out.emplace_back(idx[j], dist[j] * dist[j]);
    }
    return;
  }
  // The tree's cells bound the positions it was built on; a point now within `radius` was then
  // within radius + slack.
  const float q[3] = {cloud.x[i], cloud.y[i], cloud.z[i]};
  tree_->Radius(q, radius + slack_, out);
  const float r2 = radius * radius;
  std::erase_if(out, [&](const auto& m) { return cloud.removed(m.first) || m.second >= r2; });
}

}  // namespace scanprep
