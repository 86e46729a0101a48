// SPDX-License-Identifier: Apache-2.0
// Parameters are declared once (kind, default, range) and checked before any stage runs: every
// numeric parameter of every stage swept over hostile values ends in a result that used the value
// as given or in INVALID_ARGUMENT naming it; never a crash, never another code (CI runs this under
// ASan+UBSan). Choice parameters are reported as text.
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "absl/strings/str_cat.h"

#include "core/base/field_error.h"
#include "core/pipeline/pipeline.h"
#include "core/sim/scan_simulator.h"
#include "tests/support/planned_stages.h"

namespace scanprep {
namespace {

using sim::Part;

const std::vector<std::string> kAllStages = {"neighbourhoods", "outliers",     "normals",
                                             "measures",       "registration", "correction",
                                             "health",         "smoothing",    "simplification"};

// Two overlapping scans of the box (so correction has work), about 3,000 points with spikes.
const PointCloud& SmallCloud() {
  static const PointCloud cloud = [] {
    PointCloud c =
        sim::SimulateWithPointCount(Part::kBoxWithBore,
                                    sim::TwoOverlappingSensors(Part::kBoxWithBore), 3000, 0.01, 7)
            .cloud;
    c.FinishLoading();
    return c;
  }();
  return cloud;
}

// The overrides that make a stage read `name` at all (LoOP and Mitra parameters).
ParamOverrides Context(const std::string& name) {
  if (name.starts_with("outliers.loop_")) return {{"outliers.method", "loop"}};
  if (name.starts_with("normals.mitra_")) return {{"normals.radius_mode", "mitra"}};
  return {};
}

// The value the report gives for `name`, plain or for the first scan.
std::optional<double> Reported(const PipelineReport& report, const std::string& name) {
  for (const StageReport& stage : report.stages) {
    for (const std::string& key : {name, name + ".scan0"}) {
      auto it = stage.parameters.find(key);
      if (it != stage.parameters.end()) return it->second;
    }
  }
  return std::nullopt;
}

// Whether the declaration admits `value`, read off the spec by hand: finite, whole for an
// integer, inside the interval, and (for a subset of the k-NN graph) at most the default k = 20.
bool Admits(const ParamSpec& spec, double value) {
  if (!std::isfinite(value)) return false;
  if (spec.kind == ParamKind::kInteger && std::floor(value) != value) return false;
  const ParamRange& r = spec.range;
  const bool above_min = r.min_inclusive ? value >= r.min : value > r.min;
  const bool below_max = r.max_inclusive ? value <= r.max : value < r.max;
  return above_min && below_max && (spec.at_most.empty() || value <= 20);
}

TEST(Params, EveryNumericParameterSurvivesHostileValues) {
  const double inf = std::numeric_limits<double>::infinity();
  size_t runs = 0, refused = 0;
  for (const ParamSpec& spec : AllParamSpecs()) {
    if (spec.kind == ParamKind::kChoice) continue;
    // The hostile values, and the ends of the declared range (admitted only if inclusive).
    std::vector<double> values = {-1,           0,   1e-30, 1e30,           4294967296.0,
                                  std::nan(""), inf, -inf,  spec.range.min, spec.range.max};
    for (const double value : values) {
      SCOPED_TRACE(spec.name + " = " + FormatNumber(value));
      PointCloud cloud = SmallCloud();
      PipelineOptions options{.stages = kAllStages, .params = Context(spec.name)};
      options.params[spec.name] = FormatNumber(value);
      CancelToken cancel;
      auto report = RunPipeline(cloud, options, cancel);
      ++runs;
      if (!Admits(spec, value)) {
        ++refused;
        ASSERT_EQ(report.status().code(), absl::StatusCode::kInvalidArgument) << report.status();
        const std::string message(report.status().message());
        EXPECT_TRUE(message.starts_with("options.params['" + spec.name + "']")) << message;
        continue;
      }
      // A value the spec admits is used as given, unless it is a radius beyond the data's own
      // scale: then the report has the smaller value used and counts the cap.
      ASSERT_TRUE(report.ok()) << report.status();
      const std::optional<double> used = Reported(*report, spec.name);
      ASSERT_TRUE(used.has_value());
      const std::string stage = spec.name.substr(0, spec.name.find('.'));
      if (Reported(*report, stage + ".radii_capped").value_or(0) > 0 && *used < value) continue;
      EXPECT_NEAR(*used, value, 1e-6 * std::abs(value));  // per-scan values are stored as float
    }
  }
  std::printf("%zu runs, %zu refused before any stage\n", runs, refused);
}

TEST(Params, IntegerOverflowIsRefusedWithTheRange) {
  const PipelineOptions rounds{.params = {{"correction.rounds", "1e30"}}};
  EXPECT_EQ(ValidateOptions(rounds),
            FieldError("options.params['correction.rounds']", "1e+30 is outside [1, 1000]"));
  const PipelineOptions orientation{.params = {{"normals.orientation_k", "1e30"}}};
  EXPECT_EQ(ValidateOptions(orientation),
            FieldError("options.params['normals.orientation_k']", "1e+30 is outside [1, 64]"));
  const PipelineOptions wrapped{.params = {{"smoothing.iterations", "4294967297"}}};
  EXPECT_EQ(ValidateOptions(wrapped),
            FieldError("options.params['smoothing.iterations']", "4294967297 is outside [0, 7]"));
}

TEST(Params, IntegersMustBeWholeAndFinite) {
  EXPECT_EQ(ValidateOptions({.params = {{"correction.rounds", "2.5"}}}),
            FieldError("options.params['correction.rounds']", "2.5 is not an integer"));
  EXPECT_EQ(ValidateOptions({.params = {{"neighbourhoods.k", "nan"}}}),
            FieldError("options.params['neighbourhoods.k']",
                       "'nan' is not a finite number in decimal notation"));
  EXPECT_TRUE(ValidateOptions({.params = {{"correction.rounds", "1000"}}}).ok());
  EXPECT_TRUE(ValidateOptions({.params = {{"correction.rounds", "1e3"}}}).ok());
}

// Decimal notation only: the parser underneath also reads hexadecimal and blanks.
TEST(Params, NumbersAreDecimal) {
  for (const char* text : {"0x7", "0x1p3", " 5", "5 ", "1e", ".", "+", "5e+", "1_0", "inf"}) {
    EXPECT_EQ(ValidateOptions({.params = {{"smoothing.lambda", text}}}),
              FieldError("options.params['smoothing.lambda']",
                         absl::StrCat("'", text, "' is not a finite number in decimal notation")))
        << text;
  }
  for (const char* text : {"0.5", "+.5", "-0", "1.", "5e-1", "0.05E+1", "01"}) {
    EXPECT_TRUE(ValidateOptions({.params = {{"smoothing.lambda", text}}}).ok()) << text;
  }
}

TEST(Params, OpenEndsAreExcluded) {
  EXPECT_EQ(ValidateOptions({.params = {{"normals.mitra_epsilon", "1"}}}),
            FieldError("options.params['normals.mitra_epsilon']", "1 is outside (0, 1)"));
  EXPECT_EQ(ValidateOptions({.params = {{"correction.radius_mm", "0"}}}),
            FieldError("options.params['correction.radius_mm']", "0 is outside (0, 10000]"));
  EXPECT_TRUE(ValidateOptions({.params = {{"smoothing.tolerance_mm", "0"}}}).ok());
}

// outliers.k reads the shared graph: it may not exceed neighbourhoods.k, given or default (20).
TEST(Params, SubsetsOfTheGraphAreBoundedByItsK) {
  EXPECT_EQ(ValidateOptions({.params = {{"outliers.k", "30"}}}),
            FieldError("options.params['outliers.k']", "30 is above neighbourhoods.k = 20"));
  EXPECT_EQ(ValidateOptions({.params = {{"neighbourhoods.k", "8"}, {"outliers.loop_k", "9"}}}),
            FieldError("options.params['outliers.loop_k']", "9 is above neighbourhoods.k = 8"));
  EXPECT_TRUE(ValidateOptions({.params = {{"neighbourhoods.k", "32"}, {"outliers.k", "30"}}}).ok());
}

// A wrong value is refused before the first stage starts: nothing runs, nothing changes.
TEST(Params, AWrongValueStopsTheJobBeforeAnyStage) {
  PointCloud cloud = SmallCloud();
  const PointCloud before = cloud;
  std::vector<std::string> started;
  CancelToken cancel;
  auto report =
      RunPipeline(cloud,
                  {.stages = {"outliers", "normals", "measures", "correction", "smoothing"},
                   .params = {{"smoothing.lambda", "1.5"}}},
                  cancel, [&](const ProgressEvent& e) { started.emplace_back(e.stage); });
  EXPECT_EQ(report.status(),
            FieldError("options.params['smoothing.lambda']", "1.5 is outside [0, 1]"));
  EXPECT_TRUE(started.empty()) << started.front();
  EXPECT_EQ(cloud.x, before.x);
  EXPECT_EQ(cloud.flags, before.flags);
}

// Every parameter a stage declares is in its report: numbers (plain or per scan) and choices,
// defaults as declared, overrides as given.
TEST(Params, TheReportListsEveryParameterUsed) {
  PointCloud cloud = SmallCloud();
  CancelToken cancel;
  auto report = RunPipeline(
      cloud, {.stages = kAllStages, .params = {{"smoothing.influence", "gauss"}}}, cancel);
  ASSERT_TRUE(report.ok()) << report.status();
  for (const StageReport& stage : report->stages) {
    for (const ParamSpec& spec : FindOfferedStage(stage.name)->params) {
      if (spec.name.starts_with("outliers.loop_") || spec.name.starts_with("normals.mitra_")) {
        continue;  // read only by the other method
      }
      if (spec.kind == ParamKind::kChoice) {
        EXPECT_TRUE(stage.text_parameters.contains(spec.name)) << spec.name;
      } else {
        EXPECT_TRUE(stage.parameters.contains(spec.name) ||
                    stage.parameters.contains(spec.name + ".scan0"))
            << spec.name;
      }
    }
  }
  auto text = [&](const std::string& stage, const std::string& name) {
    for (const StageReport& s : report->stages) {
      if (s.name == stage && s.text_parameters.contains(name)) return s.text_parameters.at(name);
    }
    return std::string("(missing)");
  };
  EXPECT_EQ(text("outliers", "outliers.method"), "nn");
  EXPECT_EQ(text("smoothing", "smoothing.influence"), "gauss");
  EXPECT_EQ(text("smoothing", "smoothing.tolerance"), "reject");
  EXPECT_EQ(text("correction", "correction.mode"), "gather");
}

// A parameter whose cost grows linearly with its value is held to a range that keeps the job
// within 3× its default's cost. Each smoothing pass repeats the stage's work, so the most passes
// cost the default job (every stage's measured cost_weight) plus that many more of smoothing's.
TEST(Params, SmoothingPassesKeepTheJobWithinThreeTimesItsDefaultCost) {
  double job = 0;
  for (const std::string& stage : kAllStages) job += FindOfferedStage(stage)->cost_weight;
  const double most = FindParam("smoothing.iterations")->range.max;
  EXPECT_LE(job + (most - 1) * FindOfferedStage("smoothing")->cost_weight, 3 * job) << most;
}

// A flat square scan, `side`² points 0.1 mm apart (Δs = 0.1 mm, u = 0.01 mm), rows as scanlines.
PointCloud Square(int side) {
  PointCloud cloud;
  cloud.kind = ScannerKind::kLine;
  cloud.scans.push_back(ScanMeta{.id = "square",
                                 .view_direction = Eigen::Vector3d::UnitZ(),
                                 .scanline_spacing = 0.1,
                                 .uncertainty = 0.01});
  for (int r = 0; r < side; ++r) {
    for (int c = 0; c < side; ++c) {
      cloud.x.push_back(c * 0.1f);
      cloud.y.push_back(r * 0.1f);
      cloud.z.push_back(0.f);
      cloud.scanline.push_back(r);
    }
  }
  cloud.FinishLoading();
  return cloud;
}

// The work counter of every stage that asks balls of r_p = max(r_min, d_k) (normals, outliers'
// surface test, smoothing): the points such a ball holds, on average over the square's middle.
double MeanAdaptiveBallPoints(const ParamOverrides& overrides, PipelineReport& report) {
  PointCloud cloud = Square(100);
  testing::PlannedStages job(cloud, {"neighbourhoods"}, overrides);
  EXPECT_TRUE(job.Run().ok());
  const Neighbourhoods& nb = job.neighbourhoods();
  RadiusMatches ball;
  double points = 0, balls = 0;
  for (size_t i = 0; i < cloud.size(); ++i) {
    if (std::min({cloud.x[i], cloud.y[i], 9.9f - cloud.x[i], 9.9f - cloud.y[i]}) < 2.5f) continue;
    nb.Within(cloud, i, nb.adaptive_radius(i), ball);
    points += double(ball.size());
    ++balls;
  }
  report = job.report();
  return points / balls;
}

// r_min from an override (or metadata) far beyond the data's scale is held to 3·r_g: r_g is the
// median d_k, so a ball of r_g holds about k = 20 points, one of 3·r_g about 9·k on a surface
// (at the former 5·r_g, 25·k: every ball-asking stage did 25 times its default work).
TEST(Params, MinRadiusOverridesKeepBallsNearTheDataScale) {
  PipelineReport report;
  const double ordinary = MeanAdaptiveBallPoints({}, report);
  EXPECT_LT(ordinary, 2 * 20.0);
  for (const char* name : {"neighbourhoods.min_radius_mm", "neighbourhoods.epsilon_u_mm"}) {
    SCOPED_TRACE(name);
    const double forced = MeanAdaptiveBallPoints({{name, "1e4"}}, report);
    EXPECT_LE(forced, 12 * 20.0);
    EXPECT_GE(forced, 6 * 20.0);  // still raised to the cap, not dropped
    const std::map<std::string, double>& p = report.stages.back().parameters;
    EXPECT_EQ(p.at("neighbourhoods.radii_capped"), 1);
    EXPECT_NEAR(p.at("neighbourhoods.min_radius_used_mm"),
                3 * p.at("neighbourhoods.global_radius_mm"), 1e-9);
  }
}

}  // namespace
}  // namespace scanprep
