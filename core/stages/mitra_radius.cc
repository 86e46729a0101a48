// SPDX-License-Identifier: Apache-2.0
#include "core/stages/mitra_radius.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include "core/spatial/local_moments.h"

namespace scanprep {
namespace {

// Largest absolute principal curvature of h = a u² + b uv + c v² (+ linear and constant terms,
// so an off-centre p does not bias the fit), in the PCA frame of the neighbourhood.
double QuadricCurvature(const PointCloud& cloud, size_t i, const RadiusMatches& matches) {
  const Eigen::Vector3d p = cloud.point(i).cast<double>();
  MomentAccumulator moments;
  for (const auto& [j, d2] : matches) moments.Add(cloud.point(j).cast<double>() - p, 1.0);
  const LocalFrame frame = moments.Solve();
  if (!frame.valid || matches.size() < 6) return 0.0;
  Eigen::Matrix<double, 6, 6> normal_eq = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 1> rhs = Eigen::Matrix<double, 6, 1>::Zero();
  for (const auto& [j, d2] : matches) {
    const Eigen::Vector3d local =
        frame.axes.transpose() * (cloud.point(j).cast<double>() - p - frame.centroid);
    const double u = local[2], v = local[1], h = local[0];
    Eigen::Matrix<double, 6, 1> row;
    row << u * u, u * v, v * v, u, v, 1.0;
    normal_eq += row * row.transpose();
    rhs += h * row;
  }
  const Eigen::Matrix<double, 6, 1> coef = normal_eq.ldlt().solve(rhs);
  Eigen::Matrix2d hessian;
  hessian << 2 * coef[0], coef[1], coef[1], 2 * coef[2];
  const Eigen::Vector2d eig =
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(hessian, Eigen::EigenvaluesOnly).eigenvalues();
  const double kappa = eig.cwiseAbs().maxCoeff();
  return std::isfinite(kappa) ? kappa : 0.0;
}

}  // namespace

float MitraRadius(const PointCloud& cloud, const Neighbourhoods& nb, size_t i, double sigma,
                  const MitraOptions& options, RadiusMatches& scratch) {
  const uint32_t k = nb.k();
  if (k == 0) return nb.min_radius(i);
  const double r_floor = std::max(
      double(nb.min_radius(i)), double(nb.knn_dist(cloud, i, std::min(options.min_points, k) - 1)));
  const double r_ceiling = std::max(r_floor, options.r_max);
  double r = nb.knn_dist(cloud, i, std::min<uint32_t>(15, k) - 1);
  for (int it = 0; it < options.max_iterations; ++it) {
    nb.Within(cloud, i, static_cast<float>(r), scratch);
    const double rho = scratch.size() / (std::numbers::pi * r * r);
    const double kappa = std::max(options.kappa_min, QuadricCurvature(cloud, i, scratch));
    const double next =
        std::clamp(std::cbrt((options.c1 * sigma / std::sqrt(options.epsilon * rho) +
                              options.c2 * sigma * sigma) /
                             kappa),
                   r_floor, r_ceiling);
    const bool converged = std::abs(next - r) < options.tolerance * r;
    r = next;
    if (converged) break;
  }
  return static_cast<float>(r);
}

}  // namespace scanprep
