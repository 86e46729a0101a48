// SPDX-License-Identifier: Apache-2.0
// The "neighbourhoods" stage: builds the shared grid and k-NN graph and reports the derived
// global radius, density and minimum radius. Every stage that uses them has it as a prerequisite,
// so the plan runs it first; listing it explicitly changes nothing.
#include "core/stages/neighbourhoods_stage.h"

#include <algorithm>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "core/base/status_macros.h"
#include "core/spatial/scanline_gap.h"
#include "core/stages/scanline_plausibility.h"
#include "core/stages/stage_context.h"
#include "core/stages/stage_names.h"

namespace scanprep {
namespace {

// r_min is held to this multiple of r_g, tighter than Build()'s own backstop
// (kMaxRadiusPerGlobalRadius): no ball of normals, outliers or smoothing is smaller than r_min,
// and with r_min at 5·r_g they held about 17 times an ordinary ball's points, a job 3.5× its
// default's time (100 k points through the service); at 3·r_g 1.8×. 3·r_g still reaches the
// neighbouring scanlines (√3·Δs) of a sensor whose scanlines lie up to about 20 point spacings
// apart; beyond that, a spacing the data bears out is kept (MinRadiusLimits).
constexpr double kMinRadiusPerGlobalRadius = 3.0;

// Names the scans (the first few, then a count) for a warning.
std::string ScanList(const PointCloud& cloud, const std::vector<size_t>& scans) {
  constexpr size_t kNamed = 3;
  std::vector<std::string> names;
  for (size_t k = 0; k < std::min(scans.size(), kNamed); ++k) {
    names.push_back(absl::StrCat("'", cloud.scans[scans[k]].id, "'"));
  }
  std::string list = absl::StrJoin(names, ", ");
  if (scans.size() > kNamed) absl::StrAppend(&list, " and ", scans.size() - kNamed, " more");
  return list;
}

// A line scanner without Δs loses Eq. 2's √3·Δs term (r_min = ε_u only, so the balls at the
// scanline gaps may hold one line); a scan without u runs on the 0.1 mm default for ε_u, the
// curvature window and the smoothing limit δ. Both are counted and warned about, not assumed.
void WarnAboutMissingMetadata(const PointCloud& cloud, bool radius_forced, StageReporter& out) {
  std::vector<size_t> no_spacing, no_uncertainty;
  for (size_t s = 0; s < cloud.scans.size(); ++s) {
    const ScanMeta& scan = cloud.scans[s];
    if (cloud.kind == ScannerKind::kLine && !(scan.scanline_spacing > 0)) no_spacing.push_back(s);
    if (!scan.uncertainty_stated) no_uncertainty.push_back(s);
  }
  out.Record("neighbourhoods.scans_without_spacing", static_cast<double>(no_spacing.size()));
  out.Record("neighbourhoods.scans_default_uncertainty",
             static_cast<double>(no_uncertainty.size()));
  if (!no_spacing.empty() && !radius_forced) {
    out.Warn(WarningCode::kNoScanlineSpacing,
             absl::StrCat("neighbourhoods: line scan(s) ", ScanList(cloud, no_spacing),
                          " state no scanline spacing, so r_min (Eq. 2) is ε_u alone; give "
                          "scanline_spacing, or neighbourhoods.min_radius_mm"));
  }
  if (!no_uncertainty.empty()) {
    out.Warn(WarningCode::kNoUncertainty,
             absl::StrCat("neighbourhoods: scan(s) ", ScanList(cloud, no_uncertainty),
                          " state no measuring uncertainty u; the default ", ScanMeta{}.uncertainty,
                          " mm is used for ε_u, the curvature window and the smoothing limit; "
                          "give the scanner's uncertainty"));
  }
}

// The most r_min of each scan may be: kMinRadiusPerGlobalRadius·r_g, or for a line scan whose
// requested r_min is beyond that, Eq. 2 on its own measured scanline gap with a quarter's margin
// (ScanlineGaps). A stated spacing the data bears out is kept however far it lies beyond r_g:
// a sensor whose profiles lie 100 point spacings apart has r_g at a tenth of the gap, and held
// to 3·r_g every ball held one profile, a line whose fitted "plane" stands on edge (every normal
// wrong, none invalid). A spacing in the wrong unit is not borne out and is held to 3·r_g.
absl::StatusOr<std::vector<double>> MinRadiusLimits(const PointCloud& cloud,
                                                    const Neighbourhoods& nb,
                                                    const std::vector<double>& requested,
                                                    const std::vector<double>& epsilon_u,
                                                    const CancelToken& cancel) {
  const double limit = kMinRadiusPerGlobalRadius * nb.global_radius();
  std::vector<double> reach(requested.size(), 0.0);
  for (size_t s = 0; s < requested.size(); ++s) {
    if (cloud.kind == ScannerKind::kLine && requested[s] > limit) reach[s] = requested[s];
  }
  std::vector<double> held(requested.size(), limit);
  SCANPREP_ASSIGN_OR_RETURN(const std::vector<double> gap, ScanlineGaps(cloud, nb, reach, cancel));
  for (size_t s = 0; s < held.size(); ++s) {
    if (gap[s] > 0) {
      // ε_u held to r_g: a u in the wrong unit is not borne out by the gap.
      const double margin = std::min(epsilon_u[s], nb.global_radius());
      held[s] = std::max(limit, MinRadiusFromScanlineSpacing(1.25 * gap[s], margin));
    }
  }
  return held;
}

class NeighbourhoodsStage : public Stage {
 public:
  absl::Status Run(StageContext& ctx) override {
    SCANPREP_ASSIGN_OR_RETURN(std::unique_ptr<Neighbourhoods> nb,
                              BuildNeighbourhoods(ctx.cloud(), ctx.Settings(NeighbourhoodsParams()),
                                                  ctx.duplicates_collapsed(), ctx.out()));
    ctx.SetNeighbourhoods(std::move(nb));
    return absl::OkStatus();
  }
};

}  // namespace

absl::StatusOr<std::unique_ptr<Neighbourhoods>> BuildNeighbourhoods(
    const PointCloud& cloud, const NeighbourhoodsSettings& settings, size_t duplicates_collapsed,
    StageReporter& out) {
  NeighbourhoodOptions options;
  options.k = settings.k;
  options.min_radius_held = true;  // below, by MinRadiusLimits
  // Per scan: a job mixing sensors would otherwise give the finer one the coarser one's r_min.
  std::vector<double> epsilon_u;
  for (size_t s = 0; s < cloud.scans.size(); ++s) {
    const ScanMeta& scan = cloud.scans[s];
    const double spacing = cloud.kind == ScannerKind::kLine ? scan.scanline_spacing : 0.0;
    epsilon_u.push_back(settings.epsilon_u.Or(scan.uncertainty));
    // Flexible scanners have no fixed spacing: r_min = ε_u and r_p = max(r_min, d_k) grows
    // the ball until it holds k points (docs/algorithms.md §4).
    options.min_radius.push_back(
        settings.min_radius.Or(MinRadiusFromScanlineSpacing(spacing, epsilon_u.back())));
    out.RecordForScan(settings.epsilon_u.name, s, epsilon_u.back());
    out.RecordForScan(settings.min_radius.name, s, options.min_radius.back());
  }
  WarnAboutMissingMetadata(cloud, settings.min_radius.forced.has_value(), out);
  const std::vector<double> requested = options.min_radius;
  SCANPREP_ASSIGN_OR_RETURN(std::unique_ptr<Neighbourhoods> nb,
                            Neighbourhoods::Build(cloud, options, out.cancel()));
  // r_g is known only once the graph is built, and the graph does not depend on r_min: a job
  // whose r_min exceeds the limit builds once more with it held there (the same r_g; one more
  // k-NN pass, about an eighth of a default job, instead of every ball many times too full).
  SCANPREP_ASSIGN_OR_RETURN(const std::vector<double> held,
                            MinRadiusLimits(cloud, *nb, requested, epsilon_u, out.cancel()));
  bool capped = false;
  for (size_t s = 0; s < held.size(); ++s) capped |= requested[s] > held[s];
  if (capped) {
    for (size_t s = 0; s < held.size(); ++s) {
      options.min_radius[s] = std::min(options.min_radius[s], held[s]);
    }
    nb.reset();  // before the second graph: never two at once
    SCANPREP_ASSIGN_OR_RETURN(nb, Neighbourhoods::Build(cloud, options, out.cancel()));
  }
  for (size_t s = 0; s < cloud.scans.size(); ++s) {
    out.CapRadius(absl::StrCat("the minimum radius r_min (Eq. 2, from scanline spacing and "
                               "uncertainty) of scan '",
                               cloud.scans[s].id, "'"),
                  requested[s], nb->scan_min_radius(s));
    out.RecordForScan("neighbourhoods.min_radius_used_mm", s, nb->scan_min_radius(s));
  }
  if (duplicates_collapsed > 0) {
    out.Warn(WarningCode::kDuplicatesCollapsed,
             absl::StrCat("neighbourhoods: ", duplicates_collapsed,
                          " points lie within a hundredth of the uncertainty u (one cube of "
                          "edge u/100) of another point of their scan: exact repeats or a "
                          "cluster of near-identical returns; each group was processed once "
                          "and every point of it returned with that result"));
  }
  out.Record("neighbourhoods.duplicates_collapsed", static_cast<double>(duplicates_collapsed));
  SCANPREP_RETURN_IF_ERROR(WarnIfScanlinesImplausible(cloud, *nb, out));
  out.Record("neighbourhoods.global_radius_mm", nb->global_radius());
  out.Record("neighbourhoods.density_per_mm2", nb->density());
  // Lists kept as 32-bit indices because a neighbour lies too far away in the grid's order:
  // each costs 4·k bytes instead of 2·k.
  out.Record("neighbourhoods.wide_lists", static_cast<double>(nb->wide_lists()));
  return nb;
}

const ParamTable<NeighbourhoodsSettings>& NeighbourhoodsParams() {
  using S = NeighbourhoodsSettings;
  static const ParamTable<S> table = {
      param::Integer(&S::k, "neighbourhoods.k", kDefaultNeighbourK, Closed(3, 64),
                     "neighbours per point in the shared graph (k_g)"),
      param::DerivedReal(&S::epsilon_u, "neighbourhoods.epsilon_u_mm", "the scan's uncertainty u",
                         Closed(0, 1e4), "ε_u of Eq. (2), uncertainty margin"),
      param::DerivedReal(&S::min_radius, "neighbourhoods.min_radius_mm",
                         "per scan from its scanline spacing; ε_u for flexible scanners",
                         Closed(0, 1e4), "r_min of Eq. (2): √3·Δs + ε_u"),
  };
  return table;
}

StageInfo NeighbourhoodsStageInfo() {
  return {
      .name = std::string(stage_names::kNeighbourhoods),
      .summary = "spatial grid and k-NN graph shared by all stages; global radius r_g and density",
      .params = NeighbourhoodsParams().Specs(),
      .make = [] { return std::make_unique<NeighbourhoodsStage>(); },
      .work_per_point = 5,
      .cost_weight = 1.33,
  };
}

}  // namespace scanprep
