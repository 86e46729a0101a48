// SPDX-License-Identifier: Apache-2.0
#include "core/pipeline/plan_cost.h"

#include <algorithm>
#include <cmath>
#include <map>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "core/base/status_macros.h"
#include "core/pipeline/plan.h"
#include "core/spatial/neighbourhoods.h"
#include "core/stages/correction.h"
#include "core/stages/neighbourhoods_stage.h"
#include "core/stages/normals.h"
#include "core/stages/registration.h"
#include "core/stages/smoothing.h"
#include "core/stages/stage_names.h"

namespace scanprep {
namespace {

namespace sn = stage_names;

// The model, fitted to the 100 k-point two-scan simulated job through the service (2 threads),
// every costly parameter alone and in pairs (docs/plan-cost.md).
//
// A radius that fills the balls: the stage's balls hold their cap (32·k points) instead of the
// points within r_p; each multiplier is that stage's time with the radius at its edge, k = 20.
struct Fill {
  std::string_view stage;
  double multiplier;
};
constexpr Fill kMinRadiusFills[] = {{sn::kNeighbourhoods, 2.9},
                                    {sn::kOutliers, 2.0},
                                    {sn::kSurfaceSpikes, 2.0},
                                    {sn::kNormals, 1.8},
                                    {sn::kSmoothing, 3.4}};
// Mitra's radius (Eq. 1) at c1 = c2 = 1: normals 7× its adaptive radius; raising either constant
// to 1000 fills its balls (12.5×), between them as c^0.084.
constexpr double kMitra = 7;
constexpr double kMitraExponent = 0.084;
constexpr double kMitraFull = 12.5;
// correction.radius_scale s: correction's balls grow as s^0.65 until they hold their cap (6×).
constexpr double kCorrectionScaleExponent = 0.65;
constexpr double kCorrectionFull = 6;
// neighbourhoods.k: the k-NN lists and the balls' cap grow with k. Where balls hold the points
// within r_p = max(r_min, d_k), only d_k grows (work as (k/20)^0.45); where they are full, and in
// the neighbourhood stage itself, the cap does (as (k/20)^0.8); the stages that read only the
// lists (measures, health) as (k/20)^0.3.
constexpr double kKExponentBalls = 0.45;
constexpr double kKExponentFull = 0.8;
constexpr double kKExponentLists = 0.3;

bool ReadsLists(std::string_view stage) {
  return stage == sn::kMeasures || stage == sn::kRegistration || stage == sn::kHealth;
}

// "name=value" for each of `names` the request set.
std::string Cause(const ParamOverrides& params, std::initializer_list<std::string_view> names) {
  std::vector<std::string> set;
  for (std::string_view name : names) {
    if (auto it = params.find(name); it != params.end())
      set.push_back(absl::StrCat(std::string(name), "=", it->second));
  }
  return absl::StrJoin(set, ", ");
}

// Adds the term when it costs more than the default.
void Add(std::vector<CostTerm>& terms, std::string_view stage, std::string cause,
         double multiplier) {
  if (multiplier > 1) terms.push_back({std::string(stage), std::move(cause), multiplier});
}

// The terms of the radii that fill a stage's balls.
std::vector<CostTerm> FillTerms(const ParamOverrides& params) {
  std::vector<CostTerm> terms;
  const NeighbourhoodsSettings nb = NeighbourhoodsParams().Read(params);
  if (nb.min_radius.forced.has_value()) {
    const std::string cause =
        Cause(params, {NeighbourhoodsParams().Name(&NeighbourhoodsSettings::min_radius)});
    for (const Fill& fill : kMinRadiusFills) Add(terms, fill.stage, cause, fill.multiplier);
  }
  const NormalsSettings normals = NormalsParams().Read(params);
  if (normals.mitra()) {
    const auto& table = NormalsParams();
    const double c = std::max({normals.mitra_c1, normals.mitra_c2, 1.0});
    const double multiplier = normals.mitra_max_radius_mm.forced.has_value()
                                  ? kMitraFull
                                  : std::min(kMitraFull, kMitra * std::pow(c, kMitraExponent));
    Add(terms, sn::kNormals,
        Cause(params,
              {table.Name(&NormalsSettings::radius_mode), table.Name(&NormalsSettings::mitra_c1),
               table.Name(&NormalsSettings::mitra_c2),
               table.Name(&NormalsSettings::mitra_max_radius_mm)}),
        multiplier);
  }
  const CorrectionSettings correction = CorrectionParams().Read(params);
  const double correction_multiplier =
      correction.radius.forced.has_value()
          ? kCorrectionFull
          : std::min(kCorrectionFull, std::pow(correction.radius_scale, kCorrectionScaleExponent));
  Add(terms, sn::kCorrection,
      Cause(params, {CorrectionParams().Name(&CorrectionSettings::radius_scale),
                     CorrectionParams().Name(&CorrectionSettings::radius)}),
      correction_multiplier);
  return terms;
}

double Product(const std::vector<CostTerm>& terms, std::string_view stage) {
  double product = 1;
  for (const CostTerm& t : terms) {
    if (t.stage == stage) product *= t.multiplier;
  }
  return product;
}

double WeightedWork(const Plan& plan, const std::vector<CostTerm>& terms) {
  double work = 0;
  for (const StageInfo* stage : plan.stages())
    work += stage->cost_weight * Product(terms, stage->name);
  return work;
}

}  // namespace

PlanCost EstimatePlanCost(const Plan& plan) {
  const ParamOverrides& params = plan.params();
  PlanCost cost;
  const std::vector<CostTerm> fills = FillTerms(params);
  const double k_ratio =
      NeighbourhoodsParams().Read(params).k / static_cast<double>(kDefaultNeighbourK);
  const std::string k_cause =
      Cause(params, {NeighbourhoodsParams().Name(&NeighbourhoodsSettings::k)});
  for (const StageInfo* stage : plan.stages()) {
    const bool full = std::any_of(fills.begin(), fills.end(),
                                  [&](const CostTerm& t) { return t.stage == stage->name; });
    const double exponent = ReadsLists(stage->name)                      ? kKExponentLists
                            : full || stage->name == sn::kNeighbourhoods ? kKExponentFull
                                                                         : kKExponentBalls;
    if (k_ratio > 1) cost.terms.push_back({stage->name, k_cause, std::pow(k_ratio, exponent)});
    // Balls are full once: of two radii that fill a stage's balls, the costlier one counts.
    const CostTerm* fill = nullptr;
    for (const CostTerm& t : fills) {
      if (t.stage == stage->name && (fill == nullptr || t.multiplier > fill->multiplier)) fill = &t;
    }
    if (fill != nullptr) cost.terms.push_back(*fill);
    // Registration's cost_weight is its time in the default plan; a job that allows more steps
    // is judged at its bound, each step a round of the same cost.
    if (stage->name == sn::kRegistration) {
      const auto& table = RegistrationParams();
      Add(cost.terms, sn::kRegistration,
          Cause(params, {table.Name(&RegistrationSettings::max_iterations)}),
          static_cast<double>(table.Read(params).max_iterations) / table.Read({}).max_iterations);
    }
    // Each smoothing pass costs the first one's time again.
    if (stage->name == sn::kSmoothing) {
      Add(cost.terms, sn::kSmoothing,
          Cause(params, {SmoothingParams().Name(&SmoothingSettings::iterations)}),
          SmoothingParams().Read(params).iterations);
    }
  }
  // The default plan resolves (Plan tests), whatever the job's parameters.
  static const double default_work = WeightedWork(*Plan::Resolve(DefaultStages(), {}), {});
  cost.ratio = WeightedWork(plan, cost.terms) / default_work;
  return cost;
}

absl::StatusOr<PlanCost> EstimatePlanCost(const PipelineOptions& options) {
  SCANPREP_ASSIGN_OR_RETURN(
      const Plan plan,
      Plan::Resolve(options.stages.empty() ? DefaultStages() : options.stages, options.params));
  return EstimatePlanCost(plan);
}

absl::Status CheckPlanCost(PlanCost cost, double limit) {
  if (limit <= 0 || cost.ratio <= limit) return absl::OkStatus();
  // By cause, each with the stages it multiplies, the costliest first.
  std::stable_sort(cost.terms.begin(), cost.terms.end(), [](const CostTerm& a, const CostTerm& b) {
    return a.multiplier > b.multiplier;
  });
  std::vector<std::pair<std::string, std::vector<std::string>>> causes;
  for (const CostTerm& t : cost.terms) {
    auto it = std::find_if(causes.begin(), causes.end(),
                           [&](const auto& c) { return c.first == t.cause; });
    if (it == causes.end()) it = causes.insert(causes.end(), {t.cause, {}});
    it->second.push_back(absl::StrFormat("%s ×%.3g", t.stage, t.multiplier));
  }
  std::vector<std::string> named;
  for (const auto& [cause, stages] : causes) {
    named.push_back(absl::StrCat(cause, ": ", absl::StrJoin(stages, ", ")));
  }
  return absl::ResourceExhaustedError(absl::StrFormat(
      "the plan's estimated work is %.3g× the default plan's, over the server's limit of %.3g× "
      "(max_plan_cost); parameters whose costs multiply are judged together: %s",
      cost.ratio, limit, absl::StrJoin(named, "; ")));
}

}  // namespace scanprep
