// SPDX-License-Identifier: Apache-2.0
#include "core/stages/scanline_curvature.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>

#include <Eigen/Cholesky>

#include "core/base/parallel.h"
#include "core/base/per_scan_values.h"
#include "core/base/status_macros.h"
#include "core/spatial/local_moments.h"
#include "core/stages/noise_bounds.h"

namespace scanprep {
namespace {

// [begin, end) index ranges of consecutive points sharing (scan, scanline).
std::vector<std::pair<size_t, size_t>> ScanlineRuns(const PointCloud& cloud) {
  std::vector<std::pair<size_t, size_t>> runs;
  if (!cloud.has_scanlines()) return runs;
  size_t start = 0;
  for (size_t i = 1; i <= cloud.size(); ++i) {
    if (i == cloud.size() || cloud.scanline[i] != cloud.scanline[start] ||
        cloud.scan[i] != cloud.scan[start]) {
      runs.emplace_back(start, i);
      start = i;
    }
  }
  return runs;
}

double Distance(const PointCloud& cloud, size_t a, size_t b) {
  return (cloud.point(a) - cloud.point(b)).cast<double>().norm();
}

struct LineScratch {
  std::vector<uint32_t> idx;
  std::vector<double> arc, gaps;
  std::vector<uint32_t> segment;
  // prefix[t]: moments of points [0, t) of the line relative to its first point.
  std::vector<MomentAccumulator> prefix;
  // The line's points relative to its first, read from the cloud once for all their windows.
  std::vector<Eigen::Vector3d> at;
  // One window's abscissae x, ordinates y and Gaussian weights w (first their exponents), in the
  // window's frame.
  std::vector<double> x, y;
  std::vector<float> w;
};

struct WindowFit {
  float kappa = std::numeric_limits<float>::quiet_NaN();
  float noise_per_sigma = std::numeric_limits<float>::quiet_NaN();
  float misfit = std::numeric_limits<float>::quiet_NaN();
};

// The weighted quadratic y = a0 + a1·x + a2·x² in the window's own PCA frame. In three passes,
// so that the loop that sums holds no call: frame coordinates, weights, power sums.
// Its noise: with independent noise σ on y, Cov(a) = σ²·A⁻¹BA⁻¹ for A = Σw·rowᵀrow and
// B = Σw²·rowᵀrow, so std(a2)/σ = √(vᵀBv) with v = A⁻¹e₂; and the weighted residual Σw·r² has
// the mean σ²·(Σw − tr(A⁻¹B)) (exactly: (I − H)ᵀW(I − H) = W − WH for the hat matrix H), and
// about the spread of σ²·χ²_ν/ν times that, ν = (Σw)²/Σw² − 3.
WindowFit WindowCurvature(LineScratch& s, size_t centre, size_t lo, size_t hi, double h) {
  const LocalFrame frame = s.prefix[hi + 1].Without(s.prefix[lo]).Solve();
  if (!(frame.eigenvalues[2] > 0)) return {};
  const Eigen::Vector3d tangent = frame.axes.col(2), across = frame.axes.col(1);
  const double inv_two_var = 1.0 / (2 * (h / 2) * (h / 2));
  const size_t count = hi - lo + 1;
  s.x.resize(count);
  s.y.resize(count);
  s.w.resize(count);
  for (size_t t = 0; t < count; ++t) {
    const Eigen::Vector3d d = s.at[lo + t] - s.at[centre];
    s.x[t] = d.dot(tangent);
    s.y[t] = d.dot(across);
    const double x2 = s.x[t] * s.x[t];
    s.w[t] = static_cast<float>(-x2 * inv_two_var);
  }
  for (float& w : s.w) w = std::exp(w);  // float: a weight
  // The normal equations of rows (1, x, x²) hold only the weighted power sums Σw·xᵏ, k <= 4,
  // and Σw·y·xᵏ, k <= 2; their noise the sums Σw²·xᵏ.
  double sx[5] = {0, 0, 0, 0, 0}, sy[3] = {0, 0, 0}, sq[5] = {0, 0, 0, 0, 0}, syy = 0;
  for (size_t t = 0; t < count; ++t) {
    const double w = s.w[t], x = s.x[t], y = s.y[t], x2 = x * x;
    const double wx = w * x, wx2 = w * x2;
    sx[0] += w, sx[1] += wx, sx[2] += wx2, sx[3] += wx2 * x, sx[4] += wx2 * x2;
    sy[0] += w * y, sy[1] += wx * y, sy[2] += wx2 * y, syy += w * y * y;
    sq[0] += w * w, sq[1] += w * wx, sq[2] += w * wx2, sq[3] += w * wx2 * x, sq[4] += w * wx2 * x2;
  }
  const auto hankel = [](const double(&m)[5]) {
    Eigen::Matrix3d a;
    a << m[0], m[1], m[2], m[1], m[2], m[3], m[2], m[3], m[4];
    return a;
  };
  const auto normal_eq = hankel(sx).ldlt();
  const Eigen::Vector3d b(sy[0], sy[1], sy[2]);
  const Eigen::Vector3d a = normal_eq.solve(b);
  const Eigen::Vector3d v = normal_eq.solve(Eigen::Vector3d::UnitZ());
  const Eigen::Matrix3d noise_sums = hankel(sq);
  const double slope = std::pow(1 + a[1] * a[1], 1.5);
  const double kappa = std::abs(2 * a[2]) / slope;
  const double noise = 2 * std::sqrt(std::max(0.0, v.dot(noise_sums * v))) / slope;
  // The residual's mean square per unit of its expectation, at its 99.9 % bound.
  const double expected = sx[0] - normal_eq.solve(noise_sums).trace();
  const double nu = std::max(1.0, sx[0] * sx[0] / sq[0] - 3);
  const double residual = std::max(0.0, syy - a.dot(b));
  const double misfit = residual / expected / (ChiSquareQuantile(nu, kOneSided999) / nu);
  if (!std::isfinite(kappa) || !std::isfinite(noise) || !(expected > 0)) return {};
  return {static_cast<float>(kappa), static_cast<float>(noise), static_cast<float>(misfit)};
}

void LineCurvature(const PointCloud& cloud, size_t begin, size_t end, double h,
                   const CancelToken& cancel, LineScratch& s, ScanlineCurvatures& out,
                   ScanlineCurvatureCounts& counts) {
  s.idx.clear();
  for (size_t i = begin; i < end; ++i) {
    if (!cloud.removed(i)) s.idx.push_back(static_cast<uint32_t>(i));
  }
  const size_t m = s.idx.size();
  if (m < 5) return;
  s.gaps.resize(m - 1);
  for (size_t t = 0; t + 1 < m; ++t) s.gaps[t] = Distance(cloud, s.idx[t], s.idx[t + 1]);
  s.arc.assign(s.gaps.begin(), s.gaps.end());
  std::nth_element(s.arc.begin(), s.arc.begin() + s.arc.size() / 2, s.arc.end());
  const double max_gap = 3 * s.arc[s.arc.size() / 2];
  s.arc.resize(m);
  s.segment.resize(m);
  s.arc[0] = 0;
  s.segment[0] = 0;
  for (size_t t = 1; t < m; ++t) {
    s.arc[t] = s.arc[t - 1] + s.gaps[t - 1];
    s.segment[t] = s.segment[t - 1] + (s.gaps[t - 1] > max_gap ? 1 : 0);
  }
  // Central moments do not depend on the reference point, and a line spans at most a few
  // hundred mm, so prefix sums in double keep the window's noise-level eigenvalues.
  const Eigen::Vector3d origin = cloud.point(s.idx[0]).cast<double>();
  s.prefix.resize(m + 1);
  s.prefix[0] = MomentAccumulator();
  s.at.resize(m);
  for (size_t t = 0; t < m; ++t) {
    s.at[t] = cloud.point(s.idx[t]).cast<double>() - origin;
    s.prefix[t + 1] = s.prefix[t];
    s.prefix[t + 1].Add(s.at[t], 1.0);
  }
  // The window [lo, hi] by arc length, then cut to kMaxWindowSide points a side; `reach` is
  // the uncut upper end, kept so that both ends still move forward only.
  size_t lo = 0, reach = 0;
  for (size_t t = 0; t < m; ++t) {
    if (cancel.CancelledAt(t)) return;
    while (s.segment[lo] != s.segment[t] || s.arc[t] - s.arc[lo] > h) ++lo;
    if (reach < t) reach = t;
    while (reach + 1 < m && s.segment[reach + 1] == s.segment[t] &&
           s.arc[reach + 1] - s.arc[t] <= h) {
      ++reach;
    }
    const size_t first = std::max(lo, t - std::min(t, kMaxWindowSide));
    const size_t last = std::min(reach, t + kMaxWindowSide);
    if (t - first < 2 || last - t < 2) continue;  // a segment end: the caller falls back
    counts.windows_capped += first != lo || last != reach;
    counts.window_points += last - first + 1;
    const WindowFit fit = WindowCurvature(s, t, first, last, h);
    out.kappa[s.idx[t]] = fit.kappa;
    out.noise_per_sigma[s.idx[t]] = fit.noise_per_sigma;
    out.misfit[s.idx[t]] = fit.misfit;
  }
}

}  // namespace

absl::StatusOr<std::vector<double>> MedianScanlineSpacing(const PointCloud& cloud,
                                                          const CancelToken& cancel) {
  const std::vector<std::pair<size_t, size_t>> runs = ScanlineRuns(cloud);
  SCANPREP_ASSIGN_OR_RETURN(std::vector<std::vector<float>> gaps,
                            ValuesPerScan(
                                cloud, runs.size(), cancel,
                                [&](size_t r, const auto& add) {
                                  const auto [begin, end] = runs[r];
                                  size_t previous = end;
                                  for (size_t i = begin; i < end; ++i) {
                                    if (cloud.removed(i)) continue;
                                    if (previous != end)
                                      add(cloud.scan[i],
                                          static_cast<float>(Distance(cloud, previous, i)));
                                    previous = i;
                                  }
                                },
                                8));
  std::vector<double> spacing(cloud.scans.size(), 0.0);
  for (size_t s = 0; s < gaps.size(); ++s) spacing[s] = UpperMedian(gaps[s]);
  return spacing;
}

absl::Status ScanlineCurvature(const PointCloud& cloud, const std::vector<double>& window,
                               const CancelToken& cancel, ScanlineCurvatures& out,
                               ScanlineCurvatureCounts& counts) {
  out.kappa.assign(cloud.size(), std::numeric_limits<float>::quiet_NaN());
  out.noise_per_sigma.assign(cloud.size(), std::numeric_limits<float>::quiet_NaN());
  out.misfit.assign(cloud.size(), std::numeric_limits<float>::quiet_NaN());
  const std::vector<std::pair<size_t, size_t>> runs = ScanlineRuns(cloud);
  std::atomic<size_t> capped{0}, points{0};
  absl::Status status = ParallelFor(
      runs.size(), cancel,
      [&](size_t begin, size_t end) {
        LineScratch scratch;
        ScanlineCurvatureCounts local;
        for (size_t r = begin; r < end; ++r) {
          const auto [first, last] = runs[r];
          LineCurvature(cloud, first, last, window[cloud.scan[first]], cancel, scratch, out, local);
        }
        capped += local.windows_capped;
        points += local.window_points;
      },
      8);
  counts.windows_capped = capped;
  counts.window_points = points;
  return status;
}

}  // namespace scanprep
