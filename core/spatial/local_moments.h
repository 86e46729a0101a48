// SPDX-License-Identifier: Apache-2.0
// Weighted second moments of a small point set and their eigen-decomposition (docs/algorithms.md
// §6, Eq. 4): the one PCA used by normal estimation, the Mitra radius and the scanline frame.
#pragma once

#include <cstddef>

#include <Eigen/Core>

namespace scanprep {

struct LocalFrame {
  Eigen::Vector3d eigenvalues = Eigen::Vector3d::Zero();  // λ0 <= λ1 <= λ2
  Eigen::Matrix3d axes = Eigen::Matrix3d::Identity();     // column c belongs to eigenvalue c
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();     // weighted mean, relative coordinates
  bool valid = false;  // >= 3 points and not collinear (λ1 >= 1e-12·λ2)

  Eigen::Vector3d normal() const { return axes.col(0); }
  // σ = λ0 / (λ0 + λ1 + λ2), Pauly's surface variation (Eq. 12).
  double surface_variation() const;
};

// Accumulates w·d and the six distinct entries of w·d·dᵀ in double for offsets d taken relative
// to a reference point, so large absolute coordinates do not cancel.
class MomentAccumulator {
 public:
  void Add(const Eigen::Vector3d& d, double w) {
    const double wx = w * d.x(), wy = w * d.y(), wz = w * d.z();
    const double terms[kSums] = {w,          wx,         wy,         wz,         wx * d.x(),
                                 wx * d.y(), wx * d.z(), wy * d.y(), wy * d.z(), wz * d.z()};
    for (int t = 0; t < kSums; ++t) sums_[t] += terms[t];
    ++count_;
  }
  // The moments of the points added to this one but not to `part` (an earlier state of the
  // same running sum): a sliding window as the difference of two prefix sums.
  MomentAccumulator Without(const MomentAccumulator& part) const {
    MomentAccumulator rest = *this;
    for (int t = 0; t < kSums; ++t) rest.sums_[t] -= part.sums_[t];
    rest.count_ -= part.count_;
    return rest;
  }
  size_t count() const { return count_; }
  LocalFrame Solve() const;

 private:
  // Σw, Σw·d (x, y, z), Σw·d·dᵀ (xx, xy, xz, yy, yz, zz).
  static constexpr int kSums = 10;
  double sums_[kSums] = {};
  size_t count_ = 0;
};

}  // namespace scanprep
