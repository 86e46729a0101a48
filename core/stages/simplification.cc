// SPDX-License-Identifier: Apache-2.0
// Each centre p keeps m(p) = ⌊κ̂_p·n(p) + 0.5⌋ of the n(p) other points within the target spacing
// r_s (Eq. 13) and removes the rest, lowest quality first; p itself stays. Flat parts (κ̂ ≈ 0) thin
// to a Poisson-disk set of spacing r_s, edges (κ̂ ≈ 1) keep their full density. Edge centres go
// first so planar neighbourhoods cannot strip an edge; within each set better-viewed centres go
// first. Removal is a label; the grid is not rebuilt (removed points are skipped by queries).
//
// The visit order makes the result order-dependent. "tiled" runs it in parallel: space is cut into
// cells of edge 2·r_s in 8 colour classes; two cells of one colour are ≥ 2·r_s apart, so their
// centres touch disjoint points and can run at once. Deterministic, but not identical to the
// sequential result.
#include "core/stages/simplification.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <numeric>
#include <optional>

#include "absl/strings/str_cat.h"
#include "core/base/field_error.h"
#include "core/base/free_memory.h"
#include "core/base/parallel.h"
#include "core/base/quality_order.h"
#include "core/base/status_macros.h"
#include "core/stages/scan_spacing.h"
#include "core/stages/stage_context.h"
#include "core/stages/stage_names.h"

namespace scanprep {
namespace {

// The stage's settings, read once from its parameters (ReadPlan).
struct Plan {
  float spacing;          // r_s
  float edge_threshold;   // τ_E; +inf in uniform mode (no edge set)
  bool adaptive;          // false: m(p) = 0 everywhere
  float curvature_floor;  // κ̂ at or below this counts as flat in Eq. (13)
  bool tiled;             // 8-colour cells in parallel instead of the paper's sequential order
};

class Thinner {
 public:
  Thinner(PointCloud& cloud, const Neighbourhoods& nb, const PointMeasures& m, const Plan& plan)
      : cloud_(cloud), nb_(nb), m_(m), plan_(plan), locked_(cloud.size(), 0) {}

  bool InEdgeSet(uint32_t i) const { return m_.curvature[i] >= plan_.edge_threshold; }
  // A centre thins at most its nearest BallCap() points: eight times what a ball of r_s holds on
  // a surface of the cloud's global density, at least the stages' max_ball_points(). Only a
  // cluster far denser than the cloud fills it (r_s is held to 10·r_g), where every point still
  // lies in the balls of a bounded number of centres; a centre inside such a cluster thins its
  // k-NN list instead (Neighbourhoods::Within's stand-in, scaled to this cap), so its visit
  // never reads the cluster's removed points again.
  size_t BallCap() const {
    return std::max<size_t>(nb_.max_ball_points(),
                            static_cast<size_t>(std::min(8 * ExpectedBallSize(), 1e9)));
  }
  bool Full(const RadiusMatches& ball) const { return ball.size() >= BallCap(); }

  // κ̂ of Eq. (13), rescaled so that the flat-noise band [0, floor] keeps nothing.
  float KeptShare(uint32_t i) const {
    const float f = plan_.curvature_floor;
    return std::max(0.f, m_.curvature[i] - f) / (1.f - f);
  }

  // Points a ball of radius r_s holds on a surface of the cloud's global density.
  double ExpectedBallSize() const {
    return nb_.density() * std::numbers::pi * plan_.spacing * plan_.spacing + 1;
  }

  // Processes centre i (docs/algorithms.md §12 step 3); `matches` and `candidates` are reused
  // buffers.
  void Visit(uint32_t i, RadiusMatches& matches, std::vector<uint32_t>& candidates) {
    Gather(i, matches);
    Apply(i, matches, candidates);
  }

  // The read-only half of a visit: the unremoved points within r_s of centre i, the nearest
  // BallCap() where more are. Safe to run for many centres at once while nothing is being
  // removed.
  void Gather(uint32_t i, RadiusMatches& matches) const {
    matches.clear();
    if (!cloud_.removed(i)) nb_.Within(cloud_, i, plan_.spacing, matches, kRemovedMask, BallCap());
  }

  // The writing half: `matches` may be a superset gathered before other centres removed some of
  // its points; those are skipped here, so the outcome equals a visit with a fresh query (unless
  // the ball was full: a fresh one could then hold points beyond it, so Full balls are not
  // applied from a gather).
  void Apply(uint32_t i, const RadiusMatches& matches, std::vector<uint32_t>& candidates) {
    if (cloud_.removed(i)) return;
    candidates.clear();
    size_t n = 0, locked = 0;
    for (const auto& [j, d2] : matches) {
      if (j == i || cloud_.removed(j)) continue;
      ++n;
      if (locked_[j]) {
        ++locked;
      } else {
        candidates.push_back(j);
      }
    }
    const size_t keep =
        plan_.adaptive ? static_cast<size_t>(std::floor(KeptShare(i) * float(n) + 0.5f)) : 0;
    const size_t remove = n - std::min(n, std::max(keep, locked));
    // Low quality removed first; a strict total order, so the removed set does not depend on the
    // order of `candidates`. Removing them all (flat parts, uniform mode) needs no order.
    if (remove > 0 && remove < candidates.size()) {
      const auto worse = [&](uint32_t a, uint32_t b) {
        return m_.quality[a] != m_.quality[b] ? m_.quality[a] < m_.quality[b] : a < b;
      };
      std::partial_sort(candidates.begin(), candidates.begin() + remove, candidates.end(), worse);
    }
    for (size_t c = 0; c < remove; ++c) cloud_.flags[candidates[c]] |= kRemovedSimplify;
    locked_[i] = 1;
  }

 private:
  PointCloud& cloud_;
  const Neighbourhoods& nb_;
  const PointMeasures& m_;
  const Plan& plan_;
  std::vector<uint8_t> locked_;
};

// Centres in visiting order: edge set first, then descending q̂, then index, as packed keys.
absl::StatusOr<std::vector<uint32_t>> VisitOrder(const PointCloud& cloud, const PointMeasures& m,
                                                 const Thinner& thinner,
                                                 const CancelToken& cancel) {
  std::vector<uint64_t> keys;
  keys.reserve(cloud.size());
  for (uint32_t i = 0; i < cloud.size(); ++i) {
    if (cloud.removed(i)) continue;
    keys.push_back(uint64_t(thinner.InEdgeSet(i) ? 0 : 1) << 62 |
                   DescendingQualityKey(m.quality[i], i));
  }
  SCANPREP_RETURN_IF_ERROR(CancellableSort(keys, cancel));
  std::vector<uint32_t> order(keys.size());
  for (size_t v = 0; v < keys.size(); ++v) order[v] = static_cast<uint32_t>(keys[v]);
  return order;
}

// The sequential order, with the queries (most of a visit's cost) gathered ahead in parallel for a
// batch of the next centres not yet removed, then applied one by one in order. Centres are in
// quality order, so a batch is spread over the whole part and few of its centres remove one
// another's points: little gathered work is wasted, and Apply makes the result identical to one
// query per visit. A batch holds about 2^18 gathered points (2 MiB) on the cloud's global
// density, so a large r_s means fewer centres a batch rather than more memory (and fewer centres
// a batch-mate removes). A ball far fuller than that density says, or full (beside a cluster of
// near-identical points: thousands in the ball of every centre near it), is not kept but queried
// again when its turn comes, so the batch holds at most four times its share wherever the points
// are and a full ball is always a fresh one.
absl::Status RunSequential(const PointCloud& cloud, Thinner& thinner,
                           const std::vector<uint32_t>& order, StageReporter& out) {
  constexpr double kGatheredPoints = 1 << 18;
  const size_t batch = std::min(
      order.size(),
      static_cast<size_t>(std::clamp(kGatheredPoints / thinner.ExpectedBallSize(), 16.0, 4096.0)));
  const size_t most_kept = 4 * std::max<size_t>(64, static_cast<size_t>(kGatheredPoints) / batch);
  std::vector<RadiusMatches> balls(batch);
  std::vector<uint8_t> again(batch);
  RadiusMatches fresh;
  std::vector<uint32_t> centres, candidates;
  centres.reserve(batch);
  for (size_t next = 0; next < order.size();) {
    centres.clear();
    for (; next < order.size() && centres.size() < batch; ++next) {
      if (!cloud.removed(order[next])) centres.push_back(order[next]);
    }
    SCANPREP_RETURN_IF_ERROR(ParallelFor(
        centres.size(), out.cancel(),
        [&](size_t begin, size_t end) {
          for (size_t b = begin; b < end; ++b) {
            thinner.Gather(centres[b], balls[b]);
            again[b] = balls[b].capacity() > most_kept || thinner.Full(balls[b]);
            if (again[b]) balls[b] = RadiusMatches();  // frees it
          }
        },
        /*grain=*/16));
    for (size_t b = 0; b < centres.size(); ++b) {
      if (again[b]) {
        thinner.Visit(centres[b], fresh, candidates);
      } else {
        thinner.Apply(centres[b], balls[b], candidates);
      }
    }
    FreeMemory(fresh);  // one ball of a cluster: not held into the next batch
    out.Progress(double(next) / order.size());
  }
  return absl::OkStatus();
}

// The 8-colour tiling: (phase, colour, cell) groups run phase by phase, colour by colour, the
// cells of one colour in parallel, each cell's centres in the sequential order.
absl::Status RunTiled(const PointCloud& cloud, Thinner& thinner, std::vector<uint32_t> order,
                      float cell_edge, StageReporter& out) {
  Eigen::Vector3f lo = Eigen::Vector3f::Constant(std::numeric_limits<float>::max());
  for (uint32_t i : order) lo = lo.cwiseMin(cloud.point(i));
  // 20 bits per axis in the key; a cloud too wide for that gets larger cells (still ≥ 2·r_s).
  Eigen::Vector3f hi = lo;
  for (uint32_t i : order) hi = hi.cwiseMax(cloud.point(i));
  cell_edge = std::max(cell_edge, (hi - lo).maxCoeff() / float((1 << 20) - 2));
  auto key = [&](uint32_t i) {
    const Eigen::Vector3f c = ((cloud.point(i) - lo) / cell_edge).array().floor();
    const uint64_t cx = uint64_t(c.x()), cy = uint64_t(c.y()), cz = uint64_t(c.z());
    const uint64_t colour = (cx & 1) | (cy & 1) << 1 | (cz & 1) << 2;
    const uint64_t phase = thinner.InEdgeSet(i) ? 0 : 1;
    return phase << 63 | colour << 60 | cx << 40 | cy << 20 | cz;
  };
  // By key, then by position in the sequential order, which so survives within a cell. The keys
  // live only here, not per point of the cloud: the stage's peak is this sort.
  std::vector<std::pair<uint64_t, uint32_t>> ranked(order.size());
  for (size_t v = 0; v < order.size(); ++v) ranked[v] = {key(order[v]), static_cast<uint32_t>(v)};
  SCANPREP_RETURN_IF_ERROR(CancellableSort(ranked, out.cancel()));
  // Each cell's start in the new order, with its key's phase and colour (the top 4 bits).
  std::vector<size_t> cell_start;
  std::vector<uint8_t> cell_group;
  for (size_t v = 0; v < ranked.size(); ++v) {
    if (v > 0 && ranked[v].first == ranked[v - 1].first) continue;
    cell_start.push_back(v);
    cell_group.push_back(static_cast<uint8_t>(ranked[v].first >> 60));
  }
  cell_start.push_back(ranked.size());
  {
    const std::vector<uint32_t> sequential = std::move(order);
    order.resize(ranked.size());
    for (size_t v = 0; v < ranked.size(); ++v) order[v] = sequential[ranked[v].second];
  }
  FreeMemory(ranked);
  const size_t cells = cell_start.size() - 1;
  for (size_t first = 0; first < cells;) {
    const uint8_t group = cell_group[first];
    size_t last = first;
    while (last < cells && cell_group[last] == group) ++last;
    SCANPREP_RETURN_IF_ERROR(ParallelFor(
        last - first, out.cancel(),
        [&](size_t begin, size_t end) {
          RadiusMatches matches;
          std::vector<uint32_t> candidates;
          for (size_t c = first + begin; c < first + end; ++c) {
            for (size_t v = cell_start[c]; v < cell_start[c + 1]; ++v) {
              thinner.Visit(order[v], matches, candidates);
            }
          }
        },
        /*grain=*/16));
    out.Progress(double(last) / cells);
    first = last;
  }
  return absl::OkStatus();
}

// r_s at most this many r_g: a ball of it holds ~100·k points on a surface; plenty for thinning to
// a tenth of the scanner's pitch and beyond, and still a bounded amount of work per centre.
constexpr double kMaxSpacingPerGlobalRadius = 10.0;

// Default r_s: twice the scanner's own sampling pitch, √(Δs·Δp) per scan (the side of the square
// each sample covers), median over scans; nothing when no scan has a pitch (no line scan with Δs).
std::optional<double> SpacingFromPitch(const PointCloud& cloud,
                                       const std::vector<double>& point_spacing) {
  std::vector<double> pitch;
  for (size_t s = 0; s < cloud.scans.size(); ++s) {
    const double ds = cloud.kind == ScannerKind::kLine ? cloud.scans[s].scanline_spacing : 0.0;
    const double dp = point_spacing[s];
    if (ds > 0 && dp > 0) pitch.push_back(std::sqrt(ds * dp));
  }
  if (pitch.empty()) return std::nullopt;
  std::nth_element(pitch.begin(), pitch.begin() + pitch.size() / 2, pitch.end());
  return 2.0 * pitch[pitch.size() / 2];
}

// The default r_s: from the pitch, else (recorded and warned) 2/√ρ_g of the global density.
absl::StatusOr<double> DefaultSpacing(const PointCloud& cloud, const Neighbourhoods& nb,
                                      const SimplificationSettings& settings, StageReporter& out) {
  SCANPREP_ASSIGN_OR_RETURN(const std::vector<double> spacing,
                            ScanPointSpacing(cloud, &nb, out.cancel()));
  const std::optional<double> pitch = SpacingFromPitch(cloud, spacing);
  out.Record("simplification.spacing_from_density", pitch ? 0 : 1);
  if (pitch) return *pitch;
  if (!settings.spacing.forced) {
    out.Warn(WarningCode::kSpacingFromDensity,
             "simplification: no scan states a scanline spacing, so the thinning spacing is "
             "derived from the cloud's density (2/√ρ) rather than the scanner's pitch");
  }
  return nb.density() > 0 ? 2.0 / std::sqrt(nb.density()) : 0.0;
}

// The stage's plan from its parameters; r_s derived from the data unless given, and recorded.
absl::StatusOr<Plan> MakePlan(const PointCloud& cloud, const Neighbourhoods& nb,
                              const SimplificationSettings& settings, StageReporter& out) {
  Plan plan;
  plan.adaptive = settings.mode == SimplificationMode::kAdaptive;
  // r_s is held to kMaxSpacingPerGlobalRadius·r_g: a derived one beyond it comes from spacings
  // in the wrong unit, and where κ̂ keeps most points every centre's ball would be a large
  // part of the cloud. The report shows the spacing used.
  SCANPREP_ASSIGN_OR_RETURN(const double derived, DefaultSpacing(cloud, nb, settings, out));
  const double spacing = settings.spacing.Or(derived);
  plan.spacing = static_cast<float>(out.CapRadius("the thinning spacing r_s", spacing,
                                                  kMaxSpacingPerGlobalRadius * nb.global_radius()));
  out.Record(settings.spacing.name, plan.spacing);
  if (!(plan.spacing > 0)) {
    return FieldError(absl::StrCat("options.params['", settings.spacing.name, "']"),
                      "must be > 0 (no spacing could be derived from the data)");
  }
  plan.edge_threshold = static_cast<float>(settings.edge_threshold);
  plan.curvature_floor = static_cast<float>(settings.curvature_floor);
  if (!plan.adaptive) plan.edge_threshold = std::numeric_limits<float>::infinity();
  plan.tiled = settings.order == SimplificationOrder::kTiled;
  return plan;
}

class SimplificationStage : public Stage {
 public:
  absl::Status Run(StageContext& ctx) override {
    SCANPREP_ASSIGN_OR_RETURN(const Neighbourhoods* nb, ctx.neighbourhoods());
    return Simplify(ctx.cloud(), ctx.measures(), *nb, ctx.Settings(SimplificationParams()),
                    ctx.out());
  }
};

}  // namespace

absl::Status Simplify(PointCloud& cloud, const PointMeasures& m, const Neighbourhoods& nb,
                      const SimplificationSettings& settings, StageReporter& out) {
  if (m.quality.size() != cloud.size() || m.curvature.size() != cloud.size()) {
    return absl::InternalError("simplification: the measures stage left no quality/curvature");
  }
  const size_t before = cloud.CountKept();
  if (before < 2) {  // already as thin as it gets; one point gives no spacing to derive
    out.Record("simplification.removed", 0);
    return absl::OkStatus();
  }
  SCANPREP_ASSIGN_OR_RETURN(const Plan plan, MakePlan(cloud, nb, settings, out));
  Thinner thinner(cloud, nb, m, plan);
  SCANPREP_ASSIGN_OR_RETURN(std::vector<uint32_t> order,
                            VisitOrder(cloud, m, thinner, out.cancel()));
  SCANPREP_RETURN_IF_ERROR(plan.tiled
                               ? RunTiled(cloud, thinner, std::move(order), 2 * plan.spacing, out)
                               : RunSequential(cloud, thinner, order, out));
  out.Record("simplification.removed", static_cast<double>(before - cloud.CountKept()));
  return absl::OkStatus();
}

const ParamTable<SimplificationSettings>& SimplificationParams() {
  using S = SimplificationSettings;
  static const ParamTable<S> table = {
      param::Choice(&S::mode, "simplification.mode", {"adaptive", "uniform"},
                    "adaptive: Eq. (13) keeps points by curvature; uniform: κ̂ ignored"),
      param::DerivedReal(&S::spacing, "simplification.spacing_mm",
                         "2·√(Δs·Δp), median over scans; 2/√density without scanlines",
                         LeftOpen(0, 1e4), "target spacing r_s between kept points"),
      param::Real(&S::edge_threshold, "simplification.edge_threshold", 0.5, Closed(0, 1),
                  "τ_E: centres with κ̂ ≥ τ_E form the edge set, processed first"),
      param::Real(&S::curvature_floor, "simplification.curvature_floor", 0, RightOpen(0, 1),
                  "κ̂ at or below which Eq. (13) keeps no neighbours (rescaled above): suppresses "
                  "the clusters that curvature noise on flat parts would keep (0 = the paper)"),
      param::Choice(&S::order, "simplification.order", {"sequential", "tiled"},
                    "sequential (the paper's order) or tiled: 8-colour cells of edge 2·r_s in "
                    "parallel"),
  };
  return table;
}

StageInfo SimplificationStageInfo() {
  return {
      .name = std::string(stage_names::kSimplification),
      .summary =
          "thin to spacing r_s, keeping ⌊κ̂·n + 0.5⌋ neighbours per centre (Eq. 13): "
          "dense at edges, uniform on flat parts",
      .params = SimplificationParams().Specs(),
      .make = [] { return std::make_unique<SimplificationStage>(); },
      .prerequisites =
          [](const ParamOverrides&) { return stage_names::List({stage_names::kMeasures}); },
      .work_per_point = 1,
      .cost_weight = 0.4,
  };
}

}  // namespace scanprep
