// SPDX-License-Identifier: Apache-2.0
#include "core/stages/stage_context.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/stages/stage.h"

namespace scanprep {
namespace {

// A stage reading a parameter it did not declare, or with the wrong kind of default, is a
// programming error that no request can cause; the parameter sweep test reads every one.
const ParamSpec& DeclaredSpec(std::string_view name, ParamKind kind, bool derived) {
  const ParamSpec* spec = FindParam(name);
  if (spec == nullptr || spec->kind != kind ||
      (kind != ParamKind::kChoice && spec->default_value.has_value() == derived)) {
    std::fprintf(stderr, "scanprep: parameter %.*s is read against its declaration\n",
                 static_cast<int>(name.size()), name.data());
    std::abort();
  }
  return *spec;
}

}  // namespace

std::optional<double> StageContext::Overridden(std::string_view name) const {
  auto it = overrides_.find(name);
  double value = 0;
  // Validated before the job started (ValidateOverrides), so the parse succeeds.
  if (it == overrides_.end() || !absl::SimpleAtod(it->second, &value)) return std::nullopt;
  return value;
}

double StageContext::Number(std::string_view name) {
  const ParamSpec& spec = DeclaredSpec(name, ParamKind::kReal, /*derived=*/false);
  return Recorded(name, Overridden(name).value_or(*spec.default_value));
}

double StageContext::Number(std::string_view name, double derived) {
  DeclaredSpec(name, ParamKind::kReal, /*derived=*/true);
  return Recorded(name, Overridden(name).value_or(derived));
}

int64_t StageContext::Integer(std::string_view name) {
  const ParamSpec& spec = DeclaredSpec(name, ParamKind::kInteger, /*derived=*/false);
  // In range, so well inside int64_t: the conversion is exact.
  return static_cast<int64_t>(Recorded(name, Overridden(name).value_or(*spec.default_value)));
}

int64_t StageContext::Integer(std::string_view name, int64_t derived) {
  DeclaredSpec(name, ParamKind::kInteger, /*derived=*/true);
  const double value = Overridden(name).value_or(static_cast<double>(derived));
  return static_cast<int64_t>(Recorded(name, value));
}

std::string StageContext::ChoiceText(std::string_view name) {
  const ParamSpec& spec = DeclaredSpec(name, ParamKind::kChoice, /*derived=*/false);
  auto it = overrides_.find(name);
  std::string value = it != overrides_.end() ? it->second : spec.choices.front();
  report_.text_parameters[std::string(name)] = value;
  return value;
}

void StageContext::Record(std::string_view name, double value) {
  report_.parameters[std::string(name)] = value;
}

void StageContext::RecordForScan(std::string_view name, size_t scan, double value) {
  const std::string base(name);
  Record(cloud_.scans.size() > 1 ? absl::StrCat(base, ".scan", scan) : base, value);
}

double StageContext::Recorded(std::string_view name, double value) {
  Record(name, value);
  return value;
}

void StageContext::Warn(WarningCode code, std::string message,
                        std::map<std::string, std::string> params) {
  warnings_.push_back({code, std::move(message), std::move(params)});
}

double StageContext::CapRadius(std::string_view what, double radius, double limit) {
  if (!(radius > limit)) return radius;
  const std::string& stage = report_.name;
  // One warning per stage (a job of 1,000 scans would otherwise say it 1,000 times); the
  // counter has them all.
  if (report_.parameters[absl::StrCat(stage, ".radii_capped")]++ > 0) return limit;
  Warn(WarningCode::kRadiusCapped,
       absl::StrFormat("%s: %s of %g mm is more than the data's own scale allows (%g mm, a "
                       "multiple of the global radius r_g); capped at %g mm. Check the job's "
                       "unit, the scanner metadata (spacing, uncertainty) and radius overrides",
                       stage, what, radius, limit, limit),
       {{"radius_mm", absl::StrCat(radius)}, {"limit_mm", absl::StrCat(limit)}});
  return limit;
}

absl::StatusOr<const Neighbourhoods*> StageContext::neighbourhoods() const {
  if (!shared_.neighbourhoods) {
    return absl::FailedPreconditionError(
        absl::StrCat("stage '", report_.name,
                     "' asked for the shared neighbourhoods, but its plan built none before it"));
  }
  return shared_.neighbourhoods.get();
}

bool StageContext::Ran(std::string_view name) const {
  return std::find(shared_.steps_run.begin(), shared_.steps_run.end(), name) !=
         shared_.steps_run.end();
}

absl::Status StageContext::PointsMoved(float max_shift) {
  if (!shared_.neighbourhoods) return absl::OkStatus();
  return shared_.neighbourhoods->PointsMoved(cloud_, max_shift, cancel_);
}

}  // namespace scanprep
