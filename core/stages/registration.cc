// SPDX-License-Identifier: Apache-2.0
// Registration: the health stage's point-to-plane normal equations, iterated. Every round finds
// each scan's partners again from the shared k-NN lists at the points' present positions, measures
// every overlapping pair as health does (pair_misalignment.h), and solves all scans' motions
// together in one frame for the job, each group of overlapping scans' largest held fixed. A pair
// says only what it constrains: its normal equations' Schur complement over the components whose
// standard error is within registration.max_standard_error of its residual spread, the others left
// free. So correlated components move together, and a direction no overlap sees stays as the
// scanner put it. A scan whose correction grows beyond registration.max_correction spacings is put
// back where it was (a pose that wrong is not a fine registration's to fix).
#include "core/stages/registration.h"

#include <algorithm>
#include <cmath>
#include <mutex>
#include <numbers>
#include <numeric>
#include <optional>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <Eigen/QR>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/base/parallel.h"
#include "core/base/per_scan_values.h"
#include "core/base/status_macros.h"
#include "core/base/stride.h"
#include "core/spatial/centroid.h"
#include "core/stages/health.h"
#include "core/stages/pair_matches.h"
#include "core/stages/pair_misalignment.h"
#include "core/stages/stage_context.h"
#include "core/stages/stage_names.h"

namespace scanprep {
namespace {

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;

// A round reads at most this many points of each scan, an even stride of them: the solve's
// standard errors at this count are a small share of a micrometre, and a round costs the same
// at 1 M points a scan as at 100 M.
constexpr size_t kMaxPointsPerRound = 65536;
// A pair whose sampled matches are fewer than this is not fitted, whatever they stand for.
constexpr size_t kMinMatches = 64;
// The joint solve: Gauss-Seidel over the scans' 6x6 blocks until no motion changes by more than
// this (mm), or this many sweeps.
constexpr double kSweepTolerance = 1e-9;
constexpr int kMaxSweeps = 500;

// The frame every pair's equations are written in: rotations about `centre`, scaled by `extent`.
struct Frame {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  double extent = 1;
};

// x = (t, ω·extent) as the isometry p ↦ c + R(ω)(p − c) + t.
Eigen::Isometry3d Motion(const Vector6d& x, const Frame& frame) {
  const Eigen::Vector3d omega = x.tail<3>() / frame.extent;
  Eigen::Isometry3d motion = Eigen::Isometry3d::Identity();
  if (const double angle = omega.norm(); angle > 0) {
    motion.linear() = Eigen::AngleAxisd(angle, omega / angle).toRotationMatrix();
  }
  motion.translation() = frame.centre - motion.linear() * frame.centre + x.head<3>();
  return motion;
}

// How far `motion` moves the surface at the frame's extent: its shift of the centre plus its
// angle times the extent (mm).
double Size(const Eigen::Isometry3d& motion, const Frame& frame) {
  const double angle = Eigen::AngleAxisd(motion.linear()).angle();
  return (motion * frame.centre - frame.centre).norm() + angle * frame.extent;
}

// A pair's measure in a round: its residuals, and what it says about its scans' relative motion
// in the job's frame: h (x_moving − x_fixed) = g, zero where health calls the pair unconstrained.
struct PairFit {
  uint32_t fixed = 0, moving = 0;
  size_t matches = 0;
  double residual_median_mm = 0, residual_spread_mm = 0;
  Matrix6d h = Matrix6d::Zero();
  Vector6d g = Vector6d::Zero();
};

// The centroid and RMS extent of the points a round reads.
absl::StatusOr<Frame> FrameOf(const PointCloud& cloud,
                              const std::vector<std::vector<uint32_t>>& sampled,
                              const CancelToken& cancel) {
  std::vector<uint32_t> all;
  for (const auto& points : sampled) all.insert(all.end(), points.begin(), points.end());
  Frame frame;
  if (all.empty()) return frame;
  const auto at = [&](size_t i) -> Eigen::Vector3d { return cloud.point(all[i]).cast<double>(); };
  SCANPREP_ASSIGN_OR_RETURN(const Centroid c, CentroidOf(all.size(), at, cancel));
  frame.centre = c.centre;
  frame.extent = std::max(c.rms_extent, 1e-6);
  return frame;
}

// x in the frame of a pair's overlap (translation at its centre c_p, rotation scaled by its extent
// L_p) from x in the job's frame: t_p = t − (c_p − c) × (ω·L)/L, ω·L_p.
Matrix6d ToPairFrame(const Frame& job, const Eigen::Vector3d& centre, double extent) {
  const Eigen::Vector3d d = centre - job.centre;
  Eigen::Matrix3d cross;
  cross << 0, -d.z(), d.y(), d.z(), 0, -d.x(), -d.y(), d.x(), 0;
  Matrix6d m = Matrix6d::Identity();
  m.topRightCorner<3, 3>() = -cross / job.extent;
  m.bottomRightCorner<3, 3>() *= extent / job.extent;
  return m;
}

// What a pair knows of its constrained components, the others left free: the information of
// those (the Schur complement h_KK − h_KU h_UU⁺ h_UK of its normal equations, over its whitened
// residuals' variance) about its estimate of them, in the job's frame. Components health calls
// unconstrained carry no information, so no scan moves along them on this pair's word, and the
// constrained ones are undone jointly with what they are correlated with.
void SetInformation(const PairHealth& health, const PairEquations& eq, const Frame& job,
                    PairFit& fit) {
  std::vector<int> known, free;
  for (int k = 0; k < 6; ++k) (health.constrained[k] ? known : free).push_back(k);
  if (known.empty() || !(eq.unit_spread > 0)) return;
  const auto block = [&](const std::vector<int>& rows, const std::vector<int>& cols) {
    Eigen::MatrixXd out(rows.size(), cols.size());
    for (size_t a = 0; a < rows.size(); ++a) {
      for (size_t b = 0; b < cols.size(); ++b) out(a, b) = eq.h(rows[a], cols[b]);
    }
    return out;
  };
  Eigen::MatrixXd information = block(known, known);
  if (!free.empty()) {
    const Eigen::MatrixXd coupling = block(known, free);
    information -=
        coupling *
        Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd>(block(free, free)).pseudoInverse() *
        coupling.transpose();
  }
  information /= eq.unit_spread * eq.unit_spread;
  const Vector6d estimate = SolveLeastSquares(eq.h, eq.g).x;
  Matrix6d in_pair = Matrix6d::Zero();
  for (size_t a = 0; a < known.size(); ++a) {
    for (size_t b = 0; b < known.size(); ++b) in_pair(known[a], known[b]) = information(a, b);
  }
  const Matrix6d m = ToPairFrame(job, health.centre, eq.extent);
  fit.h = m.transpose() * in_pair * m;
  fit.g = m.transpose() * (in_pair * estimate);
}

// Every pair of active scans, measured at the present positions as health measures a pair (its
// components and which of them its overlap constrains), on the sampled points. `stride[s]`: how
// many of scan s's points each sampled one stands for, so a pair needs the matches that stand for
// health.min_overlap_points.
absl::StatusOr<std::vector<PairFit>> FitPairs(
    const PointCloud& cloud, const PointMeasures& m, const Neighbourhoods& nb,
    const PairSearch& search, const std::vector<std::vector<uint32_t>>& sampled,
    const std::vector<double>& stride, const std::vector<bool>& active, const Frame& frame,
    const HealthSettings& pairs, double max_standard_error, const CancelToken& cancel) {
  std::vector<PairFit> fits;
  for (uint32_t moving = 1; moving < sampled.size(); ++moving) {
    SCANPREP_ASSIGN_OR_RETURN(auto by_fixed,
                              FindCorrespondences(cloud, m, nb, search, sampled[moving], cancel));
    const MisalignmentSettings settings{
        .min_points = std::max(
            kMinMatches,
            static_cast<size_t>(std::ceil(double(pairs.min_overlap_points) / stride[moving]))),
        .max_standard_error = max_standard_error};
    for (const auto& [fixed, matches] : by_fixed) {
      if (matches.size() < settings.min_points) continue;
      PairEquations eq;
      SCANPREP_ASSIGN_OR_RETURN(
          const PairHealth health,
          EstimatePairHealth(cloud, fixed, moving, matches, settings, cancel, &eq));
      PairFit fit{.fixed = fixed,
                  .moving = moving,
                  .matches = matches.size(),
                  .residual_median_mm = health.residual_median_mm,
                  .residual_spread_mm = health.residual_spread_mm};
      // A scan put back is measured, but moves nothing and is moved by nothing.
      if (active[fixed] && active[moving]) SetInformation(health, eq, frame, fit);
      fits.push_back(std::move(fit));
    }
  }
  return fits;
}

// Per scan, the robust RMS of its residuals over its pairs (√(median² + spread²), weighted by
// the pairs' matches); nothing where it has no pair.
std::vector<std::optional<double>> ResidualRms(const std::vector<PairFit>& fits, size_t scans) {
  std::vector<double> sum(scans, 0), weight(scans, 0);
  for (const PairFit& f : fits) {
    const double squared =
        f.residual_median_mm * f.residual_median_mm + f.residual_spread_mm * f.residual_spread_mm;
    for (const uint32_t s : {f.fixed, f.moving}) {
      sum[s] += double(f.matches) * squared;
      weight[s] += double(f.matches);
    }
  }
  std::vector<std::optional<double>> rms(scans);
  for (size_t s = 0; s < scans; ++s) {
    if (weight[s] > 0) rms[s] = std::sqrt(sum[s] / weight[s]);
  }
  return rms;
}

// The largest scan of each group of scans the fits connect, by union-find; true for it.
std::vector<bool> References(const std::vector<PairFit>& fits, const std::vector<size_t>& points) {
  std::vector<uint32_t> parent(points.size());
  std::iota(parent.begin(), parent.end(), 0u);
  const auto root = [&](uint32_t s) {
    while (parent[s] != s) s = parent[s] = parent[parent[s]];
    return s;
  };
  std::vector<bool> grouped(points.size(), false);
  for (const PairFit& f : fits) {
    if (f.h.isZero()) continue;
    parent[root(f.fixed)] = root(f.moving);
    grouped[f.fixed] = grouped[f.moving] = true;
  }
  std::vector<std::optional<uint32_t>> largest(points.size());
  for (uint32_t s = 0; s < points.size(); ++s) {
    if (!grouped[s]) continue;
    std::optional<uint32_t>& best = largest[root(s)];
    if (!best || points[s] > points[*best]) best = s;
  }
  std::vector<bool> reference(points.size(), false);
  for (const auto& best : largest) {
    if (best) reference[*best] = true;
  }
  return reference;
}

// One scan's share of the joint system: the inverse of its pairs' summed normal equations over the
// components it constrains.
struct ScanBlock {
  Matrix6d inverse = Matrix6d::Zero();
  int directions = 0;        // the components it constrains
  std::vector<size_t> fits;  // the fits it is in
};

// Each scan's solve operator x_s = inverse · b_s: the pseudo-inverse of its pairs' summed
// information, so it moves only along what they constrain.
std::vector<ScanBlock> Blocks(const std::vector<PairFit>& fits, size_t scans) {
  std::vector<ScanBlock> blocks(scans);
  std::vector<Matrix6d> sum(scans, Matrix6d::Zero());
  for (size_t p = 0; p < fits.size(); ++p) {
    const PairFit& f = fits[p];
    if (f.h.isZero()) continue;
    for (const uint32_t s : {f.fixed, f.moving}) {
      sum[s] += f.h;
      blocks[s].fits.push_back(p);
    }
  }
  for (size_t s = 0; s < scans; ++s) {
    if (blocks[s].fits.empty()) continue;
    blocks[s].inverse = SolveLeastSquares(sum[s], Vector6d::Zero()).inverse;
    // inverse · sum projects onto the directions solved: its trace is their count.
    blocks[s].directions = static_cast<int>(std::lround((blocks[s].inverse * sum[s]).trace()));
  }
  return blocks;
}

// Every scan's misalignment x_s (relative to its group's reference, x = 0 there) minimising the
// pairs' residuals together: pair (f, m) says h (x_m − x_f) = g. Gauss-Seidel over the scans.
std::vector<Vector6d> SolveJointly(const std::vector<PairFit>& fits,
                                   const std::vector<ScanBlock>& blocks,
                                   const std::vector<bool>& reference) {
  std::vector<Vector6d> x(blocks.size(), Vector6d::Zero());
  for (int sweep = 0; sweep < kMaxSweeps; ++sweep) {
    double change = 0;
    for (size_t s = 0; s < blocks.size(); ++s) {
      if (reference[s] || blocks[s].directions == 0) continue;
      Vector6d b = Vector6d::Zero();
      for (const size_t p : blocks[s].fits) {
        const PairFit& f = fits[p];
        b += f.moving == s ? Vector6d(f.g + f.h * x[f.fixed]) : Vector6d(f.h * x[f.moving] - f.g);
      }
      const Vector6d next = blocks[s].inverse * b;
      change = std::max(change, (next - x[s]).cwiseAbs().maxCoeff());
      x[s] = next;
    }
    if (change < kSweepTolerance) break;
  }
  return x;
}

// Applies motion[s] to every point and normal of scan s, and to its pose.
absl::Status Move(PointCloud& cloud, const std::vector<std::optional<Eigen::Isometry3d>>& motion,
                  const CancelToken& cancel) {
  std::vector<std::optional<Eigen::Isometry3f>> single(motion.size());
  for (size_t s = 0; s < motion.size(); ++s) {
    if (!motion[s]) continue;
    single[s] = motion[s]->cast<float>();
    ScanMeta& meta = cloud.scans[s];
    const Eigen::Matrix3d turn = motion[s]->linear();
    for (auto* position : {&meta.camera_position, &meta.projector_position}) {
      if (*position) **position = *motion[s] * **position;
    }
    for (auto* direction : {&meta.view_direction, &meta.projector_direction}) {
      if (*direction) **direction = turn * **direction;
    }
  }
  const bool normals = cloud.has_normals();
  return ParallelFor(cloud.size(), cancel, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      const auto& m = single[cloud.scan[i]];
      if (!m) continue;
      const Eigen::Vector3f p = *m * cloud.point(i);
      cloud.x[i] = p.x(), cloud.y[i] = p.y(), cloud.z[i] = p.z();
      if (!normals) continue;
      const Eigen::Vector3f n = m->linear() * cloud.normal(i);
      cloud.nx[i] = n.x(), cloud.ny[i] = n.y(), cloud.nz[i] = n.z();
    }
  });
}

// Points a block of ReachFromCentre reads: each block merges one value per scan under a lock,
// so at ParallelFor's default of 1,024 a job of 100 M points and 1,000 scans would merge 10⁸ of
// them one thread at a time; 65,536 points are well under a millisecond between cancel checks.
constexpr size_t kReachGrain = size_t{1} << 16;
// The farthest any point of each scan lies from the frame's centre (bounds how far a motion moves
// it, for the neighbourhoods' re-ranking).
absl::StatusOr<std::vector<double>> ReachFromCentre(const PointCloud& cloud, const Frame& frame,
                                                    const CancelToken& cancel) {
  std::vector<double> reach(cloud.scans.size(), 0);
  std::mutex mu;
  SCANPREP_RETURN_IF_ERROR(ParallelFor(
      cloud.size(), cancel,
      [&](size_t begin, size_t end) {
        std::vector<double> part(reach.size(), 0);
        for (size_t i = begin; i < end; ++i) {
          double& r = part[cloud.scan[i]];
          r = std::max(r, (cloud.point(i).cast<double>() - frame.centre).norm());
        }
        std::lock_guard lock(mu);
        for (size_t s = 0; s < reach.size(); ++s) reach[s] = std::max(reach[s], part[s]);
      },
      kReachGrain));
  return reach;
}

// The iterations' state for every scan.
struct ScanState {
  Eigen::Isometry3d total = Eigen::Isometry3d::Identity();
  bool active = true;
  ScanRegistration report;
};

void ReportMotion(const Frame& frame, ScanState& state) {
  const Eigen::AngleAxisd turn(state.total.linear());
  ScanRegistration& r = state.report;
  r.centre = frame.centre;
  r.rotation_deg = turn.axis() * (turn.angle() * 180 / std::numbers::pi);
  // p ↦ c + R(p − c) + t, so t = T(c) − c.
  r.translation_mm = state.total * frame.centre - frame.centre;
}

// Puts back a scan whose correction outgrew its bound, and warns.
absl::Status PutBack(PointCloud& cloud, uint32_t s, double size, double limit, ScanState& state,
                     StageReporter& out) {
  std::vector<std::optional<Eigen::Isometry3d>> back(cloud.scans.size());
  back[s] = state.total.inverse();
  SCANPREP_RETURN_IF_ERROR(Move(cloud, back, out.cancel()));
  state.total = Eigen::Isometry3d::Identity();
  state.active = false;
  state.report.bound_exceeded = true;
  out.Warn(WarningCode::kRegistrationBoundExceeded,
           absl::StrFormat("scan %d (%s) needed a correction of %.4g mm, more than "
                           "registration.max_correction allows (%.4g mm): left where it was. Is "
                           "its pose off by more than a few spacings?",
                           s, cloud.scans[s].id, size, limit),
           {{"scan", absl::StrCat(s)},
            {"correction_mm", absl::StrFormat("%.6g", size)},
            {"limit_mm", absl::StrFormat("%.6g", limit)}});
  return absl::OkStatus();
}

}  // namespace

namespace {

// The stage's work in its steps: the sample and frame, the rounds, the bookkeeping at the end.
class Registrar {
 public:
  Registrar(PointCloud& cloud, const PointMeasures& m, Neighbourhoods& nb,
            const HealthSettings& pairs, const RegistrationSettings& settings, StageReporter& out)
      : cloud_(cloud), m_(m), nb_(nb), pairs_(pairs), settings_(settings), out_(out) {}

  // The partner search, the sampled points of each scan (an even stride of at most
  // kMaxPointsPerRound) and the frame every pair is written in.
  absl::Status Prepare() {
    const size_t scans = cloud_.scans.size();
    SCANPREP_ASSIGN_OR_RETURN(search_,
                              MakePairSearch(cloud_, nb_, pairs_.max_pair_distance, out_.cancel()));
    points_ = ScanPointCounts(cloud_);
    sampled_ = PointsPerScan(cloud_);
    stride_.resize(scans);
    for (size_t s = 0; s < scans; ++s) {
      const size_t kept = std::min(points_[s], kMaxPointsPerRound);
      stride_[s] = kept > 0 ? double(points_[s]) / double(kept) : 1;
      sampled_[s] = Stride(sampled_[s], kMaxPointsPerRound);
    }
    SCANPREP_ASSIGN_OR_RETURN(frame_, FrameOf(cloud_, sampled_, out_.cancel()));
    state_.resize(scans);
    for (uint32_t s = 0; s < scans; ++s) {
      state_[s].report.scan = s;
      state_[s].report.scan_id = cloud_.scans[s].id;
    }
    return absl::OkStatus();
  }

  // Measures every pair; unless this is the last round or the step would be below the tolerance
  // on every scan, solves and applies a step. False: the iterations are over.
  absl::StatusOr<bool> Round(int round) {
    const size_t scans = state_.size();
    std::vector<bool> active(scans);
    for (size_t s = 0; s < scans; ++s) active[s] = state_[s].active;
    SCANPREP_ASSIGN_OR_RETURN(const std::vector<PairFit> fits,
                              FitPairs(cloud_, m_, nb_, search_, sampled_, stride_, active, frame_,
                                       pairs_, settings_.max_standard_error, out_.cancel()));
    const std::vector<std::optional<double>> rms = ResidualRms(fits, scans);
    // A step is a linearised solve, not a promise: where it made the residuals grow (a far part
    // whose lever multiplies a rotation's error: three scans of one right surface moved 18 µm and
    // their residuals grew fourfold), it is undone and the iterations end.
    if (round > 0 && Grew(rms)) {
      SCANPREP_RETURN_IF_ERROR(UndoLastStep());
      return false;
    }
    for (size_t s = 0; s < scans; ++s) {
      if (round == 0) state_[s].report.residual_before_mm = rms[s];
      state_[s].report.residual_after_mm = rms[s];
    }
    if (round == settings_.max_iterations) return false;
    const std::vector<bool> reference = References(fits, points_);
    const std::vector<ScanBlock> blocks = Blocks(fits, scans);
    const std::vector<Vector6d> x = SolveJointly(fits, blocks, reference);
    std::vector<std::optional<Eigen::Isometry3d>> step(scans);
    bool converged = true;
    for (size_t s = 0; s < scans; ++s) {
      state_[s].report.reference = reference[s];
      state_[s].report.constrained_directions = blocks[s].directions;
      if (x[s].isZero()) continue;
      step[s] = Motion(x[s], frame_).inverse();  // undo the misalignment
      converged = converged && Size(*step[s], frame_) < settings_.tolerance * search_.spacing[s];
    }
    if (converged) return false;
    SCANPREP_RETURN_IF_ERROR(Move(cloud_, step, out_.cancel()));
    ++steps_;
    for (uint32_t s = 0; s < scans; ++s) {
      if (!step[s]) continue;
      ScanState& st = state_[s];
      st.total = *step[s] * st.total;
      ++st.report.iterations;
      const double size = Size(st.total, frame_);
      const double limit = settings_.max_correction * search_.spacing[s];
      if (size > limit) {
        SCANPREP_RETURN_IF_ERROR(PutBack(cloud_, s, size, limit, st, out_));
        step[s].reset();  // already undone whole
      }
    }
    last_step_ = std::move(step);
    out_.Progress(double(round + 1) / double(settings_.max_iterations + 1));
    return true;
  }

  // Whether the residuals, summed in squares over the scans measured before and after the last
  // step, grew.
  bool Grew(const std::vector<std::optional<double>>& rms) const {
    double before = 0, after = 0;
    for (size_t s = 0; s < rms.size(); ++s) {
      const std::optional<double>& last = state_[s].report.residual_after_mm;
      if (!rms[s] || !last) continue;
      before += *last * *last;
      after += *rms[s] * *rms[s];
    }
    return after > before;
  }

  absl::Status UndoLastStep() {
    std::vector<std::optional<Eigen::Isometry3d>> back(last_step_.size());
    for (size_t s = 0; s < back.size(); ++s) {
      if (!last_step_[s]) continue;
      back[s] = last_step_[s]->inverse();
      state_[s].total = *back[s] * state_[s].total;
      --state_[s].report.iterations;
    }
    --steps_;
    return Move(cloud_, back, out_.cancel());
  }

  // Reports every scan that overlaps another, and tells the neighbourhoods how far points moved.
  absl::Status Finish(Registration& result) {
    SCANPREP_ASSIGN_OR_RETURN(const std::vector<double> reach,
                              ReachFromCentre(cloud_, frame_, out_.cancel()));
    double max_shift = 0;
    size_t moved = 0;
    for (ScanState& st : state_) {
      ReportMotion(frame_, st);
      const double angle = Eigen::AngleAxisd(st.total.linear()).angle();
      const double shift =
          (st.total * frame_.centre - frame_.centre).norm() + angle * reach[st.report.scan];
      moved += st.report.iterations > 0;  // an undone step leaves rounding, not a move
      max_shift = std::max(max_shift, shift);
      // A scan no other overlaps has nothing to report (and 1,000 of them would grow the report
      // by their ids alone).
      if (st.report.residual_before_mm) result.scans.push_back(std::move(st.report));
    }
    if (max_shift > 0) {
      SCANPREP_RETURN_IF_ERROR(
          nb_.PointsMoved(cloud_, static_cast<float>(max_shift), out_.cancel()));
    }
    out_.Record("registration.steps", steps_);
    out_.Record("registration.scans_moved", static_cast<double>(moved));
    return absl::OkStatus();
  }

 private:
  PointCloud& cloud_;
  const PointMeasures& m_;
  Neighbourhoods& nb_;
  const HealthSettings& pairs_;
  const RegistrationSettings& settings_;
  StageReporter& out_;
  PairSearch search_;
  std::vector<size_t> points_;
  std::vector<std::vector<uint32_t>> sampled_;
  std::vector<double> stride_;
  Frame frame_;
  std::vector<ScanState> state_;
  std::vector<std::optional<Eigen::Isometry3d>> last_step_;  // the step applied last, per scan
  int steps_ = 0;
};

}  // namespace

absl::StatusOr<Registration> RegisterScans(PointCloud& cloud, const PointMeasures& m,
                                           Neighbourhoods& nb, const HealthSettings& pairs,
                                           const RegistrationSettings& settings,
                                           StageReporter& out) {
  Registration result;
  if (cloud.scans.size() < 2) {  // nothing to register against
    out.Record("registration.steps", 0);
    out.Record("registration.scans_moved", 0);
    return result;
  }
  SCANPREP_ASSIGN_OR_RETURN(result.pairs_before, MeasurePairs(cloud, m, nb, pairs, out.cancel()));
  Registrar registrar(cloud, m, nb, pairs, settings, out);
  SCANPREP_RETURN_IF_ERROR(registrar.Prepare());
  for (int round = 0;; ++round) {
    SCANPREP_ASSIGN_OR_RETURN(const bool more, registrar.Round(round));
    if (!more) break;
  }
  SCANPREP_RETURN_IF_ERROR(registrar.Finish(result));
  return result;
}

const ParamTable<RegistrationSettings>& RegistrationParams() {
  using S = RegistrationSettings;
  static const ParamTable<S> table = {
      param::Integer(&S::max_iterations, "registration.max_iterations", 10, Closed(1, 100),
                     "steps at most: each finds every scan's partners again and solves all the "
                     "scans' motions together"),
      param::Real(&S::max_correction, "registration.max_correction", 3, LeftOpen(0, 20),
                  "the largest correction a scan may receive, in its spacings (shift plus angle "
                  "times the overlap's extent); a scan that needs more is left where it was"),
      param::Real(&S::max_standard_error, "registration.max_standard_error", 0.15, Open(0, 1),
                  "a pair's component whose standard error exceeds this share of its residual "
                  "spread carries no weight: no scan moves along it on that pair's word"),
      param::Real(&S::tolerance, "registration.tolerance", 0.001, Open(0, 1),
                  "a step below this on every scan, in its spacings, ends the iterations"),
  };
  return table;
}

namespace {

class RegistrationStage : public Stage {
 public:
  absl::Status Run(StageContext& ctx) override {
    SCANPREP_ASSIGN_OR_RETURN(Neighbourhoods * nb, ctx.neighbourhoods());
    const HealthSettings pairs =
        ctx.SettingsUsing(HealthParams(), &HealthSettings::min_overlap_points,
                          &HealthSettings::max_standard_error, &HealthSettings::max_pair_distance);
    SCANPREP_ASSIGN_OR_RETURN(Registration registration,
                              RegisterScans(ctx.cloud(), ctx.measures(), *nb, pairs,
                                            ctx.Settings(RegistrationParams()), ctx.out()));
    if (!registration.scans.empty()) {
      ctx.SetRegistration(std::move(registration.pairs_before), std::move(registration.scans));
    }
    return absl::OkStatus();
  }
};

}  // namespace

StageInfo RegistrationStageInfo() {
  return {
      .name = std::string(stage_names::kRegistration),
      .summary =
          "fine registration: point-to-plane ICP of every scan against the others on the "
          "k-NN graph, along the directions the overlap constrains, within a bound",
      .params = RegistrationParams().Specs(),
      .make = [] { return std::make_unique<RegistrationStage>(); },
      .prerequisites =
          [](const ParamOverrides&) {
            return stage_names::List(
                {stage_names::kNeighbourhoods, stage_names::kNormals, stage_names::kMeasures});
          },
      .work_per_point = 1,
      .cost_weight = 0.8,
  };
}

}  // namespace scanprep
