// The "neighbourhoods" stage: builds the shared grid and k-NN graph and reports the derived
// global radius, density and minimum radius. Other stages pull it in through
// JobContext::neighbourhoods(); listing it explicitly only makes its timing visible.
#include "core/neighbourhoods_stage.h"

#include <algorithm>

#include "absl/strings/str_cat.h"

namespace scanprep {
namespace {

class NeighbourhoodsStage : public Stage {
 public:
  absl::Status Run(JobContext& ctx) override {
    const PointCloud& cloud = ctx.cloud();
    double spacing = 0, uncertainty = 0;
    for (const ScanMeta& scan : cloud.scans) {
      spacing = std::max(spacing, cloud.kind == ScannerKind::kLine ? scan.scanline_spacing : 0.0);
      uncertainty = std::max(uncertainty, scan.uncertainty);
    }
    NeighbourhoodOptions options;
    options.k = static_cast<uint32_t>(ctx.Integer("neighbourhoods.k"));
    const double epsilon_u = ctx.Number("neighbourhoods.epsilon_u_mm", uncertainty);
    // Flexible scanners have no fixed spacing: r_min = ε_u and r_p = max(r_min, d_k) grows the
    // ball until it holds k points (algorithms.md §4).
    options.min_radius =
        ctx.Number("neighbourhoods.min_radius_mm", MinRadiusFromScanlineSpacing(spacing, epsilon_u));
    auto nb = Neighbourhoods::Build(cloud, options, ctx.cancel());
    if (!nb.ok()) return nb.status();
    // Build() already held r_min to kMaxRadiusPerGlobalRadius·r_g; this reports it.
    ctx.CapRadius("the minimum radius r_min (Eq. 2, from scanline spacing and uncertainty)",
                  options.min_radius, (*nb)->min_radius());
    if (const size_t collapsed = ctx.duplicates_collapsed(); collapsed > 0) {
      ctx.Warn(absl::StrCat("neighbourhoods: ", collapsed, " points coincide exactly with another "
                            "point of their scan; each group was processed once and every "
                            "point of it returned with that result"));
    }
    ctx.Record("neighbourhoods.duplicates_collapsed", static_cast<double>(ctx.duplicates_collapsed()));
    ctx.Record("neighbourhoods.min_radius_used_mm", (*nb)->min_radius());
    ctx.Record("neighbourhoods.global_radius_mm", (*nb)->global_radius());
    ctx.Record("neighbourhoods.density_per_mm2", (*nb)->density());
    ctx.SetNeighbourhoods(*std::move(nb));
    return absl::OkStatus();
  }
};

}  // namespace

StageInfo NeighbourhoodsStageInfo() {
  return {
      .name = "neighbourhoods",
      .summary = "spatial grid and k-NN graph shared by all stages; global radius r_g and density",
      .params =
          {
              IntegerParam("neighbourhoods.k", "neighbours per point in the shared graph (k_g)",
                           20, Closed(3, 64)),
              DerivedRealParam("neighbourhoods.epsilon_u_mm", "ε_u of Eq. (2), uncertainty margin",
                               "largest scan uncertainty", Closed(0, 1e4)),
              DerivedRealParam("neighbourhoods.min_radius_mm", "r_min of Eq. (2): √3·Δs + ε_u",
                               "from scanline spacing; ε_u for flexible scanners",
                               Closed(0, 1e4)),
          },
      .make = [] { return std::make_unique<NeighbourhoodsStage>(); },
  };
}

}  // namespace scanprep
