// SPDX-License-Identifier: Apache-2.0
#include "core/spatial/local_moments.h"

#include <Eigen/Eigenvalues>

namespace scanprep {

double LocalFrame::surface_variation() const {
  const double sum = eigenvalues.sum();
  return sum > 0 ? eigenvalues[0] / sum : 0.0;
}

LocalFrame MomentAccumulator::Solve() const {
  LocalFrame frame;
  const double weight = sums_[0];
  if (count_ < 3 || !(weight > 0)) return frame;
  frame.centroid = Eigen::Vector3d(sums_[1], sums_[2], sums_[3]) / weight;
  Eigen::Matrix3d second;
  second << sums_[4], sums_[5], sums_[6],  //
      sums_[5], sums_[7], sums_[8],        //
      sums_[6], sums_[8], sums_[9];
  // Central moments M = E[d dᵀ] − E[d] E[d]ᵀ, symmetric by construction.
  const Eigen::Matrix3d m = second / weight - frame.centroid * frame.centroid.transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver;
  solver.computeDirect(m);
  // The closed form resolves eigenvalues only to ~1e-8·λ2; near-collinear sets, where the
  // 1e-12 test below decides, are redone with the iterative solver.
  if (solver.eigenvalues()[1] < 1e-6 * solver.eigenvalues()[2]) solver.compute(m);
  frame.eigenvalues = solver.eigenvalues().cwiseMax(0.0);
  frame.axes = solver.eigenvectors();
  frame.valid = frame.eigenvalues[2] > 0 && frame.eigenvalues[1] >= 1e-12 * frame.eigenvalues[2];
  return frame;
}

}  // namespace scanprep
