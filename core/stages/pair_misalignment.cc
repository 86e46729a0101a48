// SPDX-License-Identifier: Apache-2.0
// Point-to-plane: a moving point p_m near the fixed scan's point p_f, whose local plane has the
// normal n_f, lies d = n_f·(p_m − p_f) − plane_offset off it (Correspondence). If moving is fixed's
// surface moved by a small rigid motion (translation t at the centre c, rotation vector ω), d ≈
// n_f·t + ω·((p_m − c) × n_f): one linear equation J x = d per point in x = (t, ω), solved by least
// squares in two passes, each dropping the points more than 3 robust spreads off the median of what
// it explains (edges, points whose nearest fixed neighbour lies on another face). The rotation
// columns are divided by the overlap's extent L so that all six unknowns are lengths: then the
// eigenvalues of JᵀJ compare, and a flat or narrow overlap shows as eigen-directions with little
// weight, which are left out of the solve instead of being guessed from noise.
#include "core/stages/pair_misalignment.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include <Eigen/Eigenvalues>

#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "core/base/parallel.h"
#include "core/base/status_macros.h"

namespace scanprep {
namespace {

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;

// A misalignment axis is flagged when more than this share of its unit vector's squared length
// lies in the unconstrained subspace (half its length): its estimate would be mostly guesswork.
constexpr double kMaxUnconstrainedShare = 0.25;
// Points more than this many robust spreads off the median residual are left out of a pass.
constexpr double kRejectSpreads = 3.0;

struct Robust {
  double median = 0, spread = 0;
  bool Keeps(double value) const {
    return spread == 0 || std::abs(value - median) <= kRejectSpreads * spread;
  }
};

double MedianInPlace(std::vector<double>& v) {
  auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

// Median and 1.4826·MAD of `values` (O(n): two selections).
Robust MedianAndSpread(std::vector<double> values) {
  Robust r;
  r.median = MedianInPlace(values);
  for (double& v : values) v = std::abs(v - r.median);
  r.spread = RobustSpread(MedianInPlace(values));
  return r;
}

// A residual's noise is taken as at least this (mm), so that a noise-free fit does not weigh
// infinitely.
constexpr double kMinSigma = 1e-4;

// One correspondence's equation divided by its sigma, rotations scaled by 1/L.
struct Row {
  Vector6d j;
  double d = 0;
};

struct Solution {
  Vector6d x = Vector6d::Zero();  // (t, ω·L)
  std::array<bool, 6> constrained{};
};

// Least squares in the eigen-directions of JᵀJ whose eigenvalue reaches flat_ratio of the
// largest; every axis with a large share in the others is flagged and set to 0.
Solution SolveConstrained(const Matrix6d& h, const Vector6d& g, double flat_ratio) {
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eigen(h);
  const Vector6d& lambda = eigen.eigenvalues();  // ascending
  const double largest = lambda[5];
  Solution s;
  Vector6d unconstrained_share = Vector6d::Zero();
  for (int e = 0; e < 6; ++e) {
    const auto v = eigen.eigenvectors().col(e);
    if (largest > 0 && lambda[e] >= flat_ratio * largest) {
      s.x += v * (v.dot(g) / lambda[e]);
    } else {
      unconstrained_share += v.cwiseAbs2();
    }
  }
  for (int k = 0; k < 6; ++k) {
    s.constrained[k] = unconstrained_share[k] <= kMaxUnconstrainedShare;
    if (!s.constrained[k]) s.x[k] = 0;
  }
  return s;
}

// Signed distance of m's moving point from its fixed plane (mm).
double Residual(const PointCloud& cloud, const Correspondence& m) {
  const Eigen::Vector3d pm = cloud.point(m.moving).cast<double>();
  const Eigen::Vector3d pf = cloud.point(m.fixed).cast<double>();
  return m.normal.cast<double>().dot(pm - pf) - m.plane_offset;
}

// m's equation divided by its sigma, rotations scaled by 1/L (`inv_extent`), the lever taken
// from the centre c. Computed when needed rather than stored: 56 bytes a match.
Row RowOf(const PointCloud& cloud, const Correspondence& m, const Eigen::Vector3d& centre,
          double inv_extent) {
  const Eigen::Vector3d pm = cloud.point(m.moving).cast<double>();
  const Eigen::Vector3d nf = m.normal.cast<double>();
  const double weight = 1 / std::max<double>(m.sigma, kMinSigma);
  Row row;
  row.j << nf * weight, (pm - centre).cross(nf) * (inv_extent * weight);
  row.d = Residual(cloud, m) * weight;
  return row;
}

// The normal equations JᵀJ x = Jᵀd of some rows (JᵀJ's lower triangle only, until solved).
struct NormalEquations {
  Matrix6d h = Matrix6d::Zero();
  Vector6d g = Vector6d::Zero();
  NormalEquations& operator+=(const NormalEquations& other) {
    h += other.h;
    g += other.g;
    return *this;
  }
};

// values[i] = value(matches[i]) for every match, in parallel.
template <typename Value>
absl::Status Fill(std::span<const Correspondence> matches, Value value, std::vector<double>& values,
                  const CancelToken& cancel) {
  values.resize(matches.size());
  return ParallelFor(matches.size(), cancel, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) values[i] = value(matches[i]);
  });
}

// One pass: least squares over the rows whose `residual` the robust statistics keep.
template <typename MakeRow, typename RowResidual>
absl::StatusOr<Solution> Pass(std::span<const Correspondence> matches, MakeRow make_row,
                              RowResidual residual, const Robust& robust, double flat_ratio,
                              const CancelToken& cancel) {
  NormalEquations sum;
  SCANPREP_RETURN_IF_ERROR(ParallelSum(
      matches.size(), cancel, NormalEquations{},
      [&](size_t begin, size_t end) {
        NormalEquations part;
        for (size_t i = begin; i < end; ++i) {
          const Row row = make_row(matches[i]);
          if (!robust.Keeps(residual(row))) continue;
          part.h.selfadjointView<Eigen::Lower>().rankUpdate(row.j);
          part.g += row.j * row.d;
        }
        return part;
      },
      sum));
  const Matrix6d h = sum.h.selfadjointView<Eigen::Lower>();
  return SolveConstrained(h, sum.g, flat_ratio);
}

std::string Unconstrained(const std::array<bool, 6>& constrained) {
  std::vector<std::string> names;
  for (size_t k = 0; k < 6; ++k) {
    if (!constrained[k]) names.push_back(kMisalignmentAxes[k]);
  }
  return absl::StrJoin(names, ", ");
}

}  // namespace

absl::StatusOr<PairHealth> EstimatePairHealth(const PointCloud& cloud, uint32_t fixed_scan,
                                              uint32_t moving_scan,
                                              std::span<const Correspondence> matches,
                                              const MisalignmentSettings& settings,
                                              const CancelToken& cancel) {
  PairHealth pair{.fixed = fixed_scan, .moving = moving_scan, .overlap_points = matches.size()};
  if (matches.empty()) return pair;
  const double n = static_cast<double>(matches.size());
  // A concrete vector: an Eigen expression returned would refer to the point gone with the call.
  const auto moving = [&](size_t i) -> Eigen::Vector3d {
    return cloud.point(matches[i].moving).cast<double>();
  };
  Eigen::Vector3d centre;
  SCANPREP_RETURN_IF_ERROR(ParallelSum(
      matches.size(), cancel, Eigen::Vector3d::Zero().eval(),
      [&](size_t begin, size_t end) -> Eigen::Vector3d {
        Eigen::Vector3d part = Eigen::Vector3d::Zero();
        for (size_t i = begin; i < end; ++i) part += moving(i);
        return part;
      },
      centre));
  centre /= n;
  double squared_extent = 0;
  SCANPREP_RETURN_IF_ERROR(ParallelSum(
      matches.size(), cancel, 0.0,
      [&](size_t begin, size_t end) {
        double part = 0;
        for (size_t i = begin; i < end; ++i) part += (moving(i) - centre).squaredNorm();
        return part;
      },
      squared_extent));
  const double extent = std::sqrt(squared_extent / n);
  const double inv_extent = extent > 0 ? 1 / extent : 0;

  std::vector<double> residuals;
  const auto raw_residual = [&](const Correspondence& m) { return Residual(cloud, m); };
  SCANPREP_RETURN_IF_ERROR(Fill(matches, raw_residual, residuals, cancel));
  const Robust raw = MedianAndSpread(residuals);
  pair.residual_median_mm = raw.median;
  pair.residual_spread_mm = raw.spread;
  pair.centre = centre;
  if (matches.size() < settings.min_points) {
    pair.note =
        absl::StrFormat("overlap too small (%d points < %d)", matches.size(), settings.min_points);
    return pair;  // constrained: all false
  }

  // Pass 1 keeps the weighted residuals near their median; pass 2 those near what pass 1's motion
  // explains (a tilt spreads the raw residuals, which pass 1 would otherwise cut into).
  const auto row = [&](const Correspondence& m) { return RowOf(cloud, m, centre, inv_extent); };
  const auto whole = [](const Row& r) { return r.d; };
  SCANPREP_RETURN_IF_ERROR(Fill(
      matches, [&](const Correspondence& m) { return whole(row(m)); }, residuals, cancel));
  SCANPREP_ASSIGN_OR_RETURN(Solution s, Pass(matches, row, whole, MedianAndSpread(residuals),
                                             settings.flat_ratio, cancel));
  const auto left = [&](const Row& r) { return r.d - r.j.dot(s.x); };
  SCANPREP_RETURN_IF_ERROR(Fill(
      matches, [&](const Correspondence& m) { return left(row(m)); }, residuals, cancel));
  SCANPREP_ASSIGN_OR_RETURN(
      s, Pass(matches, row, left, MedianAndSpread(residuals), settings.flat_ratio, cancel));

  pair.translation_mm = s.x.head<3>();
  pair.rotation_deg = s.x.tail<3>() * inv_extent * (180 / std::numbers::pi);
  pair.constrained = s.constrained;
  if (const std::string loose = Unconstrained(s.constrained); !loose.empty()) {
    pair.note = "too flat to constrain " + loose;
  }
  return pair;
}

}  // namespace scanprep
