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

  // r_g from a seeded 1 % sample (at least min(n, 500) points): the paper's cheap global scale.
  const size_t sample = std::min(n, std::max<size_t>((n + 99) / 100, 500));
  std::vector<float> dk(sample);
  std::mt19937_64 rng(0x5ca9);
  std::uniform_int_distribution<size_t> pick(0, n - 1);
  for (size_t s = 0; s < sample; ++s) dk[s] = nb->dk(sample == n ? s : pick(rng));
  std::nth_element(dk.begin(), dk.begin() + sample / 2, dk.end());
  nb->global_radius_ = dk[sample / 2];
  nb->density_ = nb->global_radius_ > 0
                     ? k / (std::numbers::pi * nb->global_radius_ * nb->global_radius_)
                     : 0.0;
  return nb;
}

void Neighbourhoods::Within(const PointCloud& cloud, size_t i, float radius,
                            RadiusMatches& out) const {
  out.clear();
  if (k_ > 0 && radius <= dk(i)) {
    if (!cloud.removed(i)) out.emplace_back(static_cast<uint32_t>(i), 0.f);
    const auto idx = knn(i);
    const auto dist = knn_dist(i);
    for (uint32_t j = 0; j < k_ && dist[j] < radius; ++j) {
      if (!cloud.removed(idx[j])) out.emplace_back(idx[j], dist[j] * dist[j]);
    }
    return;
  }
  const float q[3] = {cloud.x[i], cloud.y[i], cloud.z[i]};
  tree_->Radius(q, radius, out);
  std::erase_if(out, [&](const auto& m) { return cloud.removed(m.first); });
}

}  // namespace scanprep
