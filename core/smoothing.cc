// Each point moves to the weighted mean of its adaptive neighbourhood N_{r_p}(p) (Eq. 8). Weights
// combine viewing quality and flatness (Eq. 6) with a distance fall-off (Eq. 9 and Fig. 3), and a
// move longer than the scan's uncertainty δ is rejected (Eq. 10): at a sharp edge the mean lies
// far off the surface, so edges keep their points while noise-level moves on flat parts pass.
#include "core/smoothing.h"

#include <algorithm>
#include <cmath>
#include <optional>

#include "core/parallel.h"

namespace scanprep {
namespace {

enum class Influence { kCubic, kGauss, kAverage };
enum Outcome : uint8_t { kKept = 0, kMoved, kClamped, kRejected };

// Φ(x) of Fig. 3: 20 % (cubic) and 13.5 % (Gaussian) weight at the rim of the neighbourhood.
float InfluenceAt(Influence kind, float x) {
  switch (kind) {
    case Influence::kCubic: return 1.f - 0.8f * x * x * x;
    case Influence::kGauss: return std::exp(-2.f * x * x);
    case Influence::kAverage: return 1.f;
  }
  return 1.f;
}

struct Settings {
  float lambda = 0.5f;
  Influence influence = Influence::kCubic;
  bool blend = false;  // scale each point's own displacement by its weight w_p
  bool clamp = false;  // shorten a long move to δ instead of rejecting it
  std::vector<float> tolerance;  // δ per scan
};

class SmoothingStage : public Stage {
 public:
  absl::Status Run(JobContext& ctx) override {
    if (absl::Status s = ctx.Require("measures"); !s.ok()) return s;
    PointCloud& cloud = ctx.cloud();
    const PointMeasures& m = ctx.measures();
    const size_t n = cloud.size();
    if (m.quality.size() != n || m.curvature.size() != n) {
      return absl::InternalError("smoothing: the measures stage left no quality/curvature");
    }
    absl::StatusOr<Settings> settings = ReadSettings(ctx);
    if (!settings.ok()) return settings.status();
    const int iterations = static_cast<int>(ctx.Integer("smoothing.iterations"));

    std::vector<float> nx(n), ny(n), nz(n);
    std::vector<uint8_t> outcome(n);
    std::vector<uint8_t> moved_ever(n, 0);
    size_t moved = 0, clamped = 0, rejected = 0;
    double shift_sum = 0;
    for (int it = 0; it < iterations; ++it) {
      auto nb = ctx.neighbourhoods();
      if (!nb.ok()) return nb.status();
      const std::span<const uint32_t> order = (*nb)->order();
      absl::Status status = ParallelFor(n, ctx.cancel(), [&](size_t begin, size_t end) {
        RadiusMatches matches;
        for (size_t v = begin; v < end; ++v) {
          const size_t i = order[v];
          outcome[i] = SmoothPoint(cloud, **nb, m, *settings, i, matches, nx[i], ny[i], nz[i]);
        }
      });
      if (!status.ok()) return status;
      float max_shift = 0;
      for (size_t i = 0; i < n; ++i) {
        if (outcome[i] == kMoved || outcome[i] == kClamped) {
          moved_ever[i] = 1;
          const float shift = (cloud.point(i) - Eigen::Vector3f(nx[i], ny[i], nz[i])).norm();
          shift_sum += shift;
          max_shift = std::max(max_shift, shift);
        }
        moved += outcome[i] == kMoved;
        clamped += outcome[i] == kClamped;
        rejected += outcome[i] == kRejected;
      }
      // Jacobi update: every new position came from the pre-pass positions.
      cloud.x.swap(nx);
      cloud.y.swap(ny);
      cloud.z.swap(nz);
      if (absl::Status s = ctx.PointsMoved(max_shift); !s.ok()) return s;
      ctx.Progress((it + 1.0) / iterations);
    }
    for (size_t i = 0; i < n; ++i) {
      if (moved_ever[i]) cloud.flags[i] |= kSmoothed;
    }
    ctx.Record("smoothing.moved", static_cast<double>(moved));
    ctx.Record("smoothing.clamped", static_cast<double>(clamped));
    ctx.Record("smoothing.rejected", static_cast<double>(rejected));
    ctx.Record("smoothing.mean_shift_mm",
               moved + clamped > 0 ? shift_sum / static_cast<double>(moved + clamped) : 0.0);
    return absl::OkStatus();
  }

 private:
  static absl::StatusOr<Settings> ReadSettings(JobContext& ctx) {
    Settings s;
    s.lambda = static_cast<float>(ctx.Number("smoothing.lambda"));
    const std::string influence = ctx.Choice("smoothing.influence");
    s.influence = influence == "gauss"     ? Influence::kGauss
                  : influence == "average" ? Influence::kAverage
                                           : Influence::kCubic;
    s.blend = ctx.Choice("smoothing.mode") == "blend";
    s.clamp = ctx.Choice("smoothing.tolerance") == "clamp";
    const PointCloud& cloud = ctx.cloud();
    const std::optional<double> forced = ctx.Overridden("smoothing.tolerance_mm");
    for (size_t scan = 0; scan < std::max<size_t>(cloud.scans.size(), 1); ++scan) {
      // δ = u: a move within the measuring uncertainty cannot be told apart from noise.
      const double u = scan < cloud.scans.size() ? cloud.scans[scan].uncertainty : 0.1;
      s.tolerance.push_back(static_cast<float>(forced.value_or(u)));
      ctx.RecordForScan("smoothing.tolerance_mm", scan, s.tolerance.back());
    }
    return s;
  }

  // Writes the new position of point i to (ox, oy, oz) and says what happened to it.
  static Outcome SmoothPoint(const PointCloud& cloud, const Neighbourhoods& nb,
                             const PointMeasures& m, const Settings& s, size_t i,
                             RadiusMatches& matches, float& ox, float& oy, float& oz) {
    const Eigen::Vector3f p = cloud.point(i);
    ox = p.x(), oy = p.y(), oz = p.z();
    if (cloud.removed(i)) return kKept;
    const float r_p = nb.adaptive_radius(i);
    if (!(r_p > 0)) return kKept;
    nb.Within(cloud, i, r_p, matches);  // includes i itself (x = 0, Φ = 1)
    auto weight = [&](uint32_t j) {      // Eq. (6): 1 = well viewed and flat
      return s.lambda * m.quality[j] + (1.f - s.lambda) * (1.f - m.curvature[j]);
    };
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    double total = 0;
    for (const auto& [j, d2] : matches) {
      const float x = std::min(1.f, std::sqrt(d2) / r_p);  // Eq. (9)
      const double w = double(weight(j)) * InfluenceAt(s.influence, x);
      sum += w * cloud.point(j).cast<double>();
      total += w;
    }
    if (total < 1e-12) return kKept;
    Eigen::Vector3d target = sum / total;  // Eq. (8)
    const Eigen::Vector3d p0 = p.cast<double>();
    if (s.blend) target = p0 + double(weight(static_cast<uint32_t>(i))) * (target - p0);
    Eigen::Vector3d step = target - p0;
    const double len = step.norm();
    const double delta = s.tolerance[cloud.scan[i]];
    Outcome outcome = kMoved;
    if (len > delta) {  // Eq. (10)
      if (!s.clamp) return kRejected;
      step *= delta / len;
      outcome = kClamped;
    }
    if (len == 0) return kKept;
    ox = static_cast<float>(p0.x() + step.x());
    oy = static_cast<float>(p0.y() + step.y());
    oz = static_cast<float>(p0.z() + step.z());
    return outcome;
  }
};

}  // namespace

StageInfo SmoothingStageInfo() {
  return {
      .name = "smoothing",
      .summary = "edge-preserving smoothing: quality/curvature-weighted mean of N_{r_p}(p), moves "
                 "longer than the uncertainty rejected (Eqs. 6-10)",
      .params =
          {
              RealParam("smoothing.lambda",
                        "λ of Eq. (6): share of viewing quality vs. flatness in w_j", 0.5,
                        Closed(0, 1)),
              ChoiceParam("smoothing.influence", "distance fall-off Φ: 1-0.8x³, e^{-2x²} or none",
                          {"cubic", "gauss", "average"}),
              ChoiceParam("smoothing.mode",
                          "mean: p' of Eq. (8); blend: p + w_p·(p' - p), each point's move "
                          "scaled by its own weight",
                          {"mean", "blend"}),
              ChoiceParam("smoothing.tolerance",
                          "a move longer than δ is rejected (Eq. 10) or clamped to δ",
                          {"reject", "clamp"}),
              DerivedRealParam("smoothing.tolerance_mm", "δ of Eq. (10)",
                               "the scan's measuring uncertainty u", Closed(0, 1e4)),
              IntegerParam("smoothing.iterations",
                           "Jacobi passes, each from the previous pass's positions", 1,
                           Closed(0, 100)),
          },
      .make = [] { return std::make_unique<SmoothingStage>(); },
  };
}

}  // namespace scanprep
