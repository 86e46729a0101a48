// SPDX-License-Identifier: Apache-2.0
// Point-to-plane: a moving point p_m near the fixed scan's point p_f, whose local plane has the
// normal n_f, lies d = n_f·(p_m − p_f) − plane_offset off it (Correspondence). If moving is fixed's
// surface moved by a small rigid motion (translation t at the centre c, rotation vector ω), d ≈
// n_f·t + ω·((p_m − c) × n_f): one linear equation J x = d per point in x = (t, ω), solved by least
// squares in two passes, each dropping the points more than 3 robust spreads off the median of what
// it explains (edges, points whose nearest fixed neighbour lies on another face). The rotation
// columns are divided by the overlap's extent L so that all six unknowns are lengths. Each
// component's standard error comes from the covariance (least squares and a jackknife over groups
// of the overlap, the larger); a flat or narrow overlap shows as components known no better than a
// share of the noise, which are flagged instead of being guessed from it.
#include "core/stages/pair_misalignment.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

#include <Eigen/Eigenvalues>

#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "core/base/parallel.h"
#include "core/base/status_macros.h"
#include "core/spatial/centroid.h"

namespace scanprep {
namespace {

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;

// An eigenvalue of JᵀJ below this share of the largest is rounding, not information.
constexpr double kNumericallyZero = 1e-12;
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

}  // namespace

LeastSquares SolveLeastSquares(const Matrix6d& h, const Vector6d& g) {
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eigen(h);
  const Vector6d& lambda = eigen.eigenvalues();  // ascending
  const double largest = lambda[5];
  LeastSquares s;
  Vector6d left_out_share = Vector6d::Zero();
  for (int e = 0; e < 6; ++e) {
    const auto v = eigen.eigenvectors().col(e);
    if (largest > 0 && lambda[e] >= kNumericallyZero * largest) {
      s.x += v * (v.dot(g) / lambda[e]);
      s.inverse += v * v.transpose() / lambda[e];
    } else {
      left_out_share += v.cwiseAbs2();
    }
  }
  for (int k = 0; k < 6; ++k) {
    s.solvable[k] = left_out_share[k] <= kNumericallyZero;
    if (!s.solvable[k]) s.x[k] = 0;
  }
  return s;
}

namespace {

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

// The overlap is cut into kGroups groups of cells kGroupCellsPerExtent to the overlap's RMS extent
// (cells hashed into groups), for the delete-a-group jackknife: neighbouring residuals are not
// independent (each fixed plane is the mean of its neighbourhood, and a few hundred moving points
// share each neighbourhood's error), so the covariance of independent rows understates how well a
// component is known, 2-5x on the simulated blocks; left-out groups wider than that correlation
// see it.
constexpr size_t kGroups = 32;
constexpr double kGroupCellsPerExtent = 8;

struct GroupedEquations {
  std::array<NormalEquations, kGroups> group;
  GroupedEquations& operator+=(const GroupedEquations& other) {
    for (size_t g = 0; g < kGroups; ++g) group[g] += other.group[g];
    return *this;
  }
  NormalEquations Total() const {
    NormalEquations total;
    for (const NormalEquations& e : group) total += e;
    return total;
  }
};

// Matches a block of a pass sums: ParallelSum holds one GroupedEquations (10.7 KB) per block, so
// beyond 4 M matches the blocks grow and stay about 1,024 (11 MB), not 2.6 bytes a match.
size_t SumGrain(size_t matches) { return std::max<size_t>(4096, matches / 1024); }

// One pass: the normal equations, per group (`group_of` a match's index), of the rows whose
// `residual` the robust statistics keep.
template <typename MakeRow, typename RowResidual, typename GroupOf>
absl::StatusOr<GroupedEquations> Pass(std::span<const Correspondence> matches, MakeRow make_row,
                                      RowResidual residual, GroupOf group_of, const Robust& robust,
                                      const CancelToken& cancel) {
  GroupedEquations sum;
  SCANPREP_RETURN_IF_ERROR(ParallelSum(
      matches.size(), cancel, GroupedEquations{},
      [&](size_t begin, size_t end) {
        GroupedEquations part;
        for (size_t i = begin; i < end; ++i) {
          const Row row = make_row(matches[i]);
          if (!robust.Keeps(residual(row))) continue;
          NormalEquations& e = part.group[group_of(i)];
          e.h.selfadjointView<Eigen::Lower>().rankUpdate(row.j);
          e.g += row.j * row.d;
        }
        return part;
      },
      sum, SumGrain(matches.size())));
  return sum;
}

LeastSquares Solve(const NormalEquations& e) {
  return SolveLeastSquares(e.h.selfadjointView<Eigen::Lower>(), e.g);
}

// The jackknife's variance of each component: (G − 1)/G · Σ (x₋g − x̄)² over the G groups that
// hold rows, x₋g solved without group g.
Vector6d JackknifeVariance(const GroupedEquations& e) {
  const NormalEquations total = e.Total();
  std::vector<Vector6d> without;
  for (const NormalEquations& g : e.group) {
    if (g.h.isZero()) continue;
    NormalEquations rest = total;
    rest.h -= g.h;
    rest.g -= g.g;
    without.push_back(Solve(rest).x);
  }
  if (without.size() < 2) return Vector6d::Zero();
  Vector6d mean = Vector6d::Zero();
  for (const Vector6d& x : without) mean += x;
  mean /= double(without.size());
  Vector6d sum = Vector6d::Zero();
  for (const Vector6d& x : without) sum += (x - mean).cwiseAbs2();
  // (G − 1)/G, and the spread of a t with G − 1 degrees of freedom against a normal's at the 95 %
  // a user reads ±2σ as (Cornish–Fisher: t ≈ z + (z³ + z)/(4ν)): 4 % more at G = 32.
  const double g = double(without.size());
  const double t_over_z = 1 + (1.96 * 1.96 + 1) / (4 * (g - 1));
  return sum * ((g - 1) / g * t_over_z * t_over_z);
}

// Each match's group: the cell of its moving point, cells kGroupCellsPerExtent to the extent,
// hashed into kGroups.
template <typename Moving>
absl::StatusOr<std::vector<uint8_t>> Groups(std::span<const Correspondence> matches, Moving moving,
                                            const Eigen::Vector3d& centre, double extent,
                                            const CancelToken& cancel) {
  const double per_mm = extent > 0 ? kGroupCellsPerExtent / extent : 0;
  std::vector<uint8_t> group(matches.size());
  SCANPREP_RETURN_IF_ERROR(ParallelFor(matches.size(), cancel, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      const Eigen::Vector3d cell = ((moving(i) - centre) * per_mm).array().floor();
      const uint64_t hash = uint64_t(int64_t(cell.x())) * 73856093u ^
                            uint64_t(int64_t(cell.y())) * 19349663u ^
                            uint64_t(int64_t(cell.z())) * 83492791u;
      group[i] = static_cast<uint8_t>(hash % kGroups);
    }
  }));
  return group;
}

// The least-squares motion of two passes, the normal equations of the second, and the spread of
// the whitened residuals it leaves.
struct Fitted {
  LeastSquares solution;
  GroupedEquations equations;
  double unit_spread = 0;
};

// Pass 1 keeps the weighted residuals near their median; pass 2 those near what pass 1's motion
// explains (a tilt spreads the raw residuals, which pass 1 would otherwise cut into).
template <typename MakeRow>
absl::StatusOr<Fitted> FitTwice(std::span<const Correspondence> matches, MakeRow row,
                                const std::vector<uint8_t>& group, const CancelToken& cancel) {
  const auto group_of = [&](size_t i) { return group[i]; };
  std::vector<double> residuals;
  const auto whole = [](const Row& r) { return r.d; };
  SCANPREP_RETURN_IF_ERROR(Fill(
      matches, [&](const Correspondence& m) { return whole(row(m)); }, residuals, cancel));
  Fitted f;
  SCANPREP_ASSIGN_OR_RETURN(
      f.equations, Pass(matches, row, whole, group_of, MedianAndSpread(residuals), cancel));
  f.solution = Solve(f.equations.Total());
  const auto left = [&](const Row& r) { return r.d - r.j.dot(f.solution.x); };
  SCANPREP_RETURN_IF_ERROR(Fill(
      matches, [&](const Correspondence& m) { return left(row(m)); }, residuals, cancel));
  SCANPREP_ASSIGN_OR_RETURN(f.equations,
                            Pass(matches, row, left, group_of, MedianAndSpread(residuals), cancel));
  f.solution = Solve(f.equations.Total());
  SCANPREP_RETURN_IF_ERROR(Fill(
      matches, [&](const Correspondence& m) { return left(row(m)); }, residuals, cancel));
  f.unit_spread = MedianAndSpread(residuals).spread;
  return f;
}

// The pair's motion and standard errors from `fitted` (rotations × `to_degrees`); a component
// whose standard error exceeds `limit` (mm, rotations as lengths at the overlap's extent) is
// flagged and reported as 0.
void SetMotion(const Fitted& fitted, double to_degrees, double limit, PairHealth& pair) {
  const LeastSquares& s = fitted.solution;
  // x's variance: the larger of the least-squares covariance's (the whitened residuals' spread
  // squared times (JᵀJ)⁺; each row was divided by its expected noise, so the spread is 1 when the
  // fits state the noise rightly) and the jackknife's over groups of the overlap.
  const Vector6d least_squares =
      fitted.unit_spread * fitted.unit_spread * s.inverse.diagonal().cwiseMax(0);
  Vector6d standard_error = least_squares.cwiseMax(JackknifeVariance(fitted.equations)).cwiseSqrt();
  for (int k = 0; k < 6; ++k) {
    if (!s.solvable[k]) standard_error[k] = std::numeric_limits<double>::infinity();
  }
  pair.translation_mm = s.x.head<3>();
  pair.rotation_deg = s.x.tail<3>() * to_degrees;
  pair.translation_se_mm = standard_error.head<3>();
  pair.rotation_se_deg = standard_error.tail<3>() * to_degrees;
  for (int k = 0; k < 6; ++k) {
    pair.constrained[k] = s.solvable[k] && standard_error[k] <= limit;
  }
  for (int k = 0; k < 6; ++k) {
    if (!pair.constrained[k]) (k < 3 ? pair.translation_mm[k] : pair.rotation_deg[k - 3]) = 0;
  }
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
                                              const CancelToken& cancel, PairEquations* equations) {
  PairHealth pair{.fixed = fixed_scan, .moving = moving_scan, .overlap_points = matches.size()};
  if (matches.empty()) return pair;
  // A concrete vector: an Eigen expression returned would refer to the point gone with the call.
  const auto moving = [&](size_t i) -> Eigen::Vector3d {
    return cloud.point(matches[i].moving).cast<double>();
  };
  SCANPREP_ASSIGN_OR_RETURN(const Centroid overlap, CentroidOf(matches.size(), moving, cancel));
  const Eigen::Vector3d centre = overlap.centre;
  const double extent = overlap.rms_extent;
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

  SCANPREP_ASSIGN_OR_RETURN(const std::vector<uint8_t> group,
                            Groups(matches, moving, centre, extent, cancel));
  const auto row = [&](const Correspondence& m) { return RowOf(cloud, m, centre, inv_extent); };
  SCANPREP_ASSIGN_OR_RETURN(const Fitted fitted, FitTwice(matches, row, group, cancel));
  SetMotion(fitted, inv_extent * (180 / std::numbers::pi), settings.max_standard_error * raw.spread,
            pair);
  if (equations != nullptr) {
    const NormalEquations total = fitted.equations.Total();
    equations->h = total.h.selfadjointView<Eigen::Lower>();
    equations->g = total.g;
    equations->extent = extent;
    equations->unit_spread = fitted.unit_spread;
  }
  if (const std::string loose = Unconstrained(pair.constrained); !loose.empty()) {
    pair.note = "too flat to constrain " + loose;
  }
  return pair;
}

}  // namespace scanprep
