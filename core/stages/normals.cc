// SPDX-License-Identifier: Apache-2.0
// Per point: the ball N_{r_p}(p), r_p = max(r_min, d_k) (or the Mitra radius), Gaussian weights
// with h = r_p/2 relative to p, the central-moment tensor in double and its smallest eigenvector.
// In overlaps only the point's own scan contributes, so a second, misregistered layer from
// another sensor does not tilt the normal that its viewing quality is later judged by.
#include "core/stages/normals.h"

#include <algorithm>
#include <atomic>
#include <cmath>

#include "absl/strings/str_cat.h"
#include "core/base/parallel.h"
#include "core/base/status_macros.h"
#include "core/spatial/ball_fit.h"
#include "core/stages/mitra_radius.h"
#include "core/stages/neighbourhoods_stage.h"
#include "core/stages/normal_orientation.h"
#include "core/stages/own_scan_noise.h"
#include "core/stages/stage_context.h"
#include "core/stages/stage_names.h"
#include "core/stages/unit_plausibility.h"

namespace scanprep {
namespace {

// Neighbours per point in the orientation graph unless the request says otherwise.
constexpr uint32_t kOrientationK = 10;

// The table's settings and what the stage derives from them and the shared neighbourhoods.
struct Resolved {
  NormalsSettings params;
  uint32_t orientation_k;
  size_t min_own_points;  // in an overlap: fewer of the point's own scan widen its ball
  MitraOptions mitra;     // kMitra
};

struct Scratch {
  RadiusMatches matches;
  RadiusMatches mitra;
};

// The unremoved points within `radius` of i, of i's own scan when `per_scan`.
void Gather(const PointCloud& cloud, const Neighbourhoods& nb, size_t i, float radius,
            bool per_scan, RadiusMatches& matches) {
  nb.Sample(cloud, i, radius, matches);
  if (per_scan) {
    std::erase_if(matches, [&](const auto& m) { return cloud.scan[m.first] != cloud.scan[i]; });
  }
}

// Every unremoved point's normal, surface variation and fit residual, and the ball radius it
// was fitted in (`radius`); flags the points without one. Returns how many fits failed.
absl::StatusOr<size_t> FitNormals(PointCloud& cloud, PointMeasures& m, const Neighbourhoods& nb,
                                  const Resolved& settings, const CancelToken& cancel,
                                  std::vector<float>& radius) {
  const size_t n = cloud.size();
  const bool per_scan = cloud.scans.size() > 1;
  cloud.nx.assign(n, 0.f);
  cloud.ny.assign(n, 0.f);
  cloud.nz.assign(n, 0.f);
  std::vector<float>& variation = m.surface_variation;
  variation.assign(n, 0.f);
  std::vector<float>& fit_rms = m.fit_rms;
  fit_rms.assign(n, 0.f);
  std::atomic<size_t> invalid{0};
  // Flags are applied after the loop: other blocks read flags[j] of their neighbours
  // (removed()) while this one would write flags[i] of the same byte.
  std::vector<uint8_t> no_normal(n, 0);

  const std::span<const uint32_t> order = nb.order();
  // A Mitra radius costs up to 5 balls of up to 5·r_g (25·k points) with a quadric fit each:
  // smaller blocks, so that a cancel does not wait for 1024 of them.
  const size_t grain = settings.params.mitra() ? 128 : 1024;
  SCANPREP_RETURN_IF_ERROR(ParallelFor(
      n, cancel,
      [&](size_t begin, size_t end) {
        Scratch scratch;
        size_t local_invalid = 0;
        for (size_t v = begin; v < end; ++v) {
          const size_t i = order[v];
          // Removed points get no normal; the flag tells clients that asked for them too.
          if (cloud.removed(i)) {
            no_normal[i] = 1;
            continue;
          }
          float r = settings.params.radius_mode == NormalsRadiusMode::kKnn ? nb.dk(i)
                                                                           : nb.adaptive_radius(i);
          if (settings.params.mitra()) {
            const double sigma =
                settings.params.mitra_sigma_mm.Or(cloud.scans[cloud.scan[i]].uncertainty);
            r = MitraRadius(cloud, nb, i, sigma, settings.mitra, scratch.mitra);
          }
          // In an overlap part of the k-NN ball belongs to other scans: widen it once
          // (OwnScanWidening). Only the widened ball is fitted. (One query reaching past r_p for
          // both balls costs more than two: a radius search grows faster than the ball.) The
          // knn mode fits the list's own-scan half as it is, and widens only below that.
          Gather(cloud, nb, i, r, per_scan, scratch.matches);
          const size_t own = scratch.matches.size();
          if (per_scan && own < settings.min_own_points) {
            r *= OwnScanWidening(own, nb.k());
            Gather(cloud, nb, i, r, per_scan, scratch.matches);
          }
          const LocalFrame frame = FitBall(cloud, i, settings.params.h_factor * r, scratch.matches);
          radius[i] = r;
          if (!frame.valid) {
            no_normal[i] = 1;
            ++local_invalid;
            continue;
          }
          const Eigen::Vector3d normal = frame.normal();
          cloud.nx[i] = static_cast<float>(normal.x());
          cloud.ny[i] = static_cast<float>(normal.y());
          cloud.nz[i] = static_cast<float>(normal.z());
          variation[i] = static_cast<float>(frame.surface_variation());
          fit_rms[i] = static_cast<float>(std::sqrt(frame.eigenvalues[0]));
        }
        invalid += local_invalid;
      },
      grain));
  for (size_t i = 0; i < n; ++i) {
    cloud.flags[i] = no_normal[i] ? cloud.flags[i] | kNormalInvalid
                                  : cloud.flags[i] & static_cast<uint8_t>(~kNormalInvalid);
  }

  return invalid.load();
}

// The fits' figures and the orientation's counts into the report.
void Report(const PointCloud& cloud, const std::vector<float>& radius, size_t invalid,
            const OrientationCounts& counts, StageReporter& out) {
  const size_t n = cloud.size();
  std::vector<float> kept;
  for (size_t i = 0; i < n; ++i) {
    if (!cloud.removed(i)) kept.push_back(radius[i]);
  }
  if (!kept.empty()) {
    std::nth_element(kept.begin(), kept.begin() + kept.size() / 2, kept.end());
    out.Record("normals.median_radius_mm", kept[kept.size() / 2]);
  }
  out.Record("normals.invalid", static_cast<double>(invalid));
  out.Record("normals.oriented_toward_sensor", static_cast<double>(counts.toward_sensor));
  out.Record("normals.oriented_by_tree", static_cast<double>(counts.propagated));
  out.Record("normals.tree_bridges", static_cast<double>(counts.bridges));
  out.Record("normals.bridge_work", static_cast<double>(counts.bridge_work));
  if (counts.propagated > 0) {
    out.Warn(WarningCode::kNormalsPropagated,
             absl::StrCat("normals: ", counts.propagated,
                          " normals oriented by spanning-tree propagation (no sensor pose); "
                          "their sign is consistent but may be globally inverted"));
  }
}

// The stage's parameters with their derived defaults (from the neighbourhoods), recorded.
Resolved Resolve(const NormalsSettings& settings, const PointCloud& cloud, const Neighbourhoods& nb,
                 StageReporter& out) {
  Resolved s{.params = settings};
  const NormalsSettings& p = s.params;
  s.min_own_points = p.radius_mode == NormalsRadiusMode::kKnn ? nb.k() / 2 : nb.k() + 1;
  // At most neighbourhoods.k (ValidateOverrides): orientation walks the shared graph.
  s.orientation_k = p.orientation_k.Or(std::min(kOrientationK, nb.k()));
  out.Record(p.orientation_k.name, s.orientation_k);
  if (!p.mitra()) return s;
  s.mitra.c1 = p.mitra_c1;
  s.mitra.c2 = p.mitra_c2;
  s.mitra.epsilon = p.mitra_epsilon;
  const double r_max_limit = kMaxRadiusPerGlobalRadius * nb.global_radius();
  s.mitra.r_max =
      out.CapRadius(p.mitra_max_radius_mm.name, p.mitra_max_radius_mm.Or(r_max_limit), r_max_limit);
  out.Record(p.mitra_max_radius_mm.name, s.mitra.r_max);  // the value used
  for (size_t scan = 0; scan < cloud.scans.size(); ++scan) {
    out.RecordForScan(p.mitra_sigma_mm.name, scan,
                      p.mitra_sigma_mm.Or(cloud.scans[scan].uncertainty));
  }
  return s;
}

class NormalsStage : public Stage {
 public:
  absl::Status Run(StageContext& ctx) override {
    SCANPREP_ASSIGN_OR_RETURN(const Neighbourhoods* nb, ctx.neighbourhoods());
    return EstimateNormals(ctx.cloud(), ctx.measures(), *nb, ctx.Settings(NormalsParams()),
                           ctx.out());
  }
};

}  // namespace

absl::Status EstimateNormals(PointCloud& cloud, PointMeasures& m, const Neighbourhoods& nb,
                             const NormalsSettings& params, StageReporter& out) {
  const Resolved settings = Resolve(params, cloud, nb, out);
  std::vector<float> radius(cloud.size(), 0.f);
  SCANPREP_ASSIGN_OR_RETURN(const size_t invalid,
                            FitNormals(cloud, m, nb, settings, out.cancel(), radius));
  SCANPREP_ASSIGN_OR_RETURN(m.own_scan_noise,
                            OwnScanNoise(cloud, nb, params.h_factor, out.cancel()));
  out.Record("normals.scans_noise_from_own_points",
             static_cast<double>(std::count_if(m.own_scan_noise.begin(), m.own_scan_noise.end(),
                                               [](const auto& v) { return v.has_value(); })));
  out.Progress(0.5);  // the normals are fitted; orientation follows
  OrientationCounts counts;
  SCANPREP_RETURN_IF_ERROR(OrientNormals(cloud, nb, settings.orientation_k, out.cancel(), counts));
  Report(cloud, radius, invalid, counts, out);
  // Here because the fits measure the noise σ̂ that the unit is judged by, and with a fail_on
  // the job then stops before any stage works in a wrong unit.
  return WarnIfUnitSuspect(cloud, m, nb, out);
}

const ParamTable<NormalsSettings>& NormalsParams() {
  using S = NormalsSettings;
  const auto mitra = [](const S& s) { return s.mitra(); };
  // Orientation walks the shared graph: at most its k.
  const std::string& graph_k = NeighbourhoodsParams().Name(&NeighbourhoodsSettings::k);
  static const ParamTable<S> table = {
      param::Choice(&S::radius_mode, "normals.radius_mode", {"adaptive", "mitra", "knn"},
                    "PCA ball radius: adaptive r_p = max(r_min, d_k), the Mitra et al. radius of "
                    "Eq. (1), or knn: d_k (the k-NN list alone, cheapest)"),
      param::Real(&S::h_factor, "normals.gaussian_h_factor", 0.5, LeftOpen(0, 10),
                  "Gaussian width h as a fraction of the ball radius"),
      param::DerivedInteger(&S::orientation_k, "normals.orientation_k",
                            absl::StrCat("min(", kOrientationK, ", ", graph_k, ")"), Closed(1, 64),
                            "neighbours per point in the orientation graph (Eq. 5)")
          .AtMost(graph_k),
      param::Real(&S::mitra_c1, "normals.mitra_c1", MitraOptions{}.c1, Closed(0, 1000),
                  "c1 of Eq. (1)")
          .When(mitra),
      param::Real(&S::mitra_c2, "normals.mitra_c2", MitraOptions{}.c2, Closed(0, 1000),
                  "c2 of Eq. (1)")
          .When(mitra),
      param::Real(&S::mitra_epsilon, "normals.mitra_epsilon", MitraOptions{}.epsilon, Open(0, 1),
                  "ε of Eq. (1): the normal bound fails with this probability")
          .When(mitra),
      param::DerivedReal(&S::mitra_sigma_mm, "normals.mitra_sigma_mm", "the scan's uncertainty u",
                         Closed(0, 1e4), "noise σ_n of Eq. (1)"),
      param::DerivedReal(&S::mitra_max_radius_mm, "normals.mitra_max_radius_mm", "5·r_g",
                         LeftOpen(0, 1e4), "upper clamp of the Mitra radius"),
  };
  return table;
}

StageInfo NormalsStageInfo() {
  return {
      .name = std::string(stage_names::kNormals),
      .summary =
          "Gaussian-weighted PCA normals (Eq. 4), oriented toward the sensor (Eq. 3) or "
          "along a minimum spanning tree (Eq. 5)",
      .params = NormalsParams().Specs(),
      .make = [] { return std::make_unique<NormalsStage>(); },
      .prerequisites =
          [](const ParamOverrides&) { return stage_names::List({stage_names::kNeighbourhoods}); },
      .work_per_point = 2,
      .cost_weight = 1.78,
  };
}

}  // namespace scanprep
