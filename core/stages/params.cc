// SPDX-License-Identifier: Apache-2.0
#include "core/stages/params.h"

#include <algorithm>
#include <charconv>
#include <cmath>

#include "absl/strings/ascii.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "core/base/did_you_mean.h"
#include "core/base/field_error.h"
#include "core/base/status_macros.h"

namespace scanprep {
namespace {

ParamSpec Numeric(std::string name, ParamKind kind, std::string description,
                  std::optional<double> default_value, std::string default_text, ParamRange range) {
  return ParamSpec{.name = std::move(name),
                   .kind = kind,
                   .description = std::move(description),
                   .default_value = default_value,
                   .default_text = std::move(default_text),
                   .range = range};
}

const ParamSpec* Find(const std::vector<ParamSpec>& specs, std::string_view name) {
  auto spec =
      std::find_if(specs.begin(), specs.end(), [&](const ParamSpec& s) { return s.name == name; });
  return spec == specs.end() ? nullptr : &*spec;
}

std::string Field(const std::string& name) { return absl::StrCat("options.params['", name, "']"); }

// Decimal notation only: [+-] digits [. digits] [e [+-] digits]. The parser underneath also takes
// hexadecimal ("0x7"), "inf", "nan" and surrounding blanks, which no one writes for a parameter on
// purpose and which read back differently elsewhere (Python's float() refuses "0x7").
bool IsDecimal(std::string_view text) {
  size_t i = 0;
  const auto digits = [&] {
    const size_t start = i;
    while (i < text.size() && absl::ascii_isdigit(static_cast<unsigned char>(text[i]))) ++i;
    return i - start;
  };
  if (i < text.size() && (text[i] == '+' || text[i] == '-')) ++i;
  size_t mantissa = digits();
  if (i < text.size() && text[i] == '.') {
    ++i;
    mantissa += digits();
  }
  if (mantissa == 0) return false;
  if (i < text.size() && (text[i] == 'e' || text[i] == 'E')) {
    ++i;
    if (i < text.size() && (text[i] == '+' || text[i] == '-')) ++i;
    if (digits() == 0) return false;
  }
  return i == text.size();
}

// A numeric override against its own spec: decimal, finite, whole for an integer, in range.
absl::Status CheckNumber(const ParamSpec& spec, const std::string& text, double& value) {
  if (!IsDecimal(text) || !absl::SimpleAtod(text, &value) || !std::isfinite(value)) {
    return FieldError(Field(spec.name),
                      absl::StrCat("'", text, "' is not a finite number in decimal notation"));
  }
  if (spec.kind == ParamKind::kInteger && std::trunc(value) != value) {
    return FieldError(Field(spec.name), absl::StrCat(FormatNumber(value), " is not an integer"));
  }
  if (!spec.range.Contains(value)) {
    return FieldError(Field(spec.name),
                      absl::StrCat(FormatNumber(value), " is outside ", spec.range.ToString()));
  }
  return absl::OkStatus();
}

// The value a checked numeric parameter will have: its override, else its default.
std::optional<double> Effective(const ParamOverrides& overrides, const ParamSpec& spec) {
  double value = 0;
  auto it = overrides.find(spec.name);
  if (it != overrides.end() && absl::SimpleAtod(it->second, &value)) return value;
  return spec.default_value;
}

}  // namespace

bool ParamRange::Contains(double value) const {
  return (min_inclusive ? value >= min : value > min) &&
         (max_inclusive ? value <= max : value < max);
}

std::string ParamRange::ToString() const {
  return absl::StrCat(min_inclusive ? "[" : "(", FormatNumber(min), ", ", FormatNumber(max),
                      max_inclusive ? "]" : ")");
}

ParamRange Closed(double min, double max) { return {min, max, true, true}; }
ParamRange LeftOpen(double min, double max) { return {min, max, false, true}; }
ParamRange RightOpen(double min, double max) { return {min, max, true, false}; }
ParamRange Open(double min, double max) { return {min, max, false, false}; }

ParamSpec RealParam(std::string_view name, std::string description, double default_value,
                    ParamRange range) {
  return Numeric(std::string(name), ParamKind::kReal, std::move(description), default_value,
                 FormatNumber(default_value), range);
}

ParamSpec DerivedRealParam(std::string_view name, std::string description, std::string rule,
                           ParamRange range) {
  return Numeric(std::string(name), ParamKind::kReal, std::move(description), std::nullopt,
                 std::move(rule), range);
}

ParamSpec IntegerParam(std::string_view name, std::string description, int64_t default_value,
                       ParamRange range) {
  return Numeric(std::string(name), ParamKind::kInteger, std::move(description),
                 static_cast<double>(default_value), FormatNumber(default_value), range);
}

ParamSpec DerivedIntegerParam(std::string_view name, std::string description, std::string rule,
                              ParamRange range) {
  return Numeric(std::string(name), ParamKind::kInteger, std::move(description), std::nullopt,
                 std::move(rule), range);
}

ParamSpec ChoiceParam(std::string_view name, std::string description,
                      std::vector<std::string> choices) {
  ParamSpec spec{.name = std::string(name),
                 .kind = ParamKind::kChoice,
                 .description = std::move(description),
                 .choices = std::move(choices)};
  spec.default_text = spec.choices.front();
  return spec;
}

std::string FormatNumber(double value) {
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, value);
  return std::string(buffer, result.ptr);
}

absl::Status ValidateOverrides(const ParamOverrides& overrides,
                               const std::vector<ParamSpec>& specs) {
  for (const auto& override : overrides) {
    // Plain references, not a structured binding: clang < 16 cannot capture bindings in lambdas.
    const std::string& name = override.first;
    const std::string& text = override.second;
    const ParamSpec* spec = Find(specs, name);
    if (spec == nullptr) {
      std::vector<std::string> known;
      for (const ParamSpec& s : specs) known.push_back(s.name);
      return FieldError(Field(name), absl::StrCat("unknown parameter", DidYouMean(name, known)));
    }
    if (spec->kind != ParamKind::kChoice) {
      double value = 0;
      SCANPREP_RETURN_IF_ERROR(CheckNumber(*spec, text, value));
    } else if (std::find(spec->choices.begin(), spec->choices.end(), text) == spec->choices.end()) {
      return FieldError(Field(name), absl::StrCat("'", text, "' is not one of ",
                                                  absl::StrJoin(spec->choices, ", ")));
    }
  }
  // Every override is valid on its own; now the bounds one parameter sets another.
  for (const ParamSpec& spec : specs) {
    const ParamSpec* bound_spec = spec.at_most.empty() ? nullptr : Find(specs, spec.at_most);
    if (bound_spec == nullptr || !overrides.contains(spec.name)) continue;
    const std::optional<double> value = Effective(overrides, spec);
    const std::optional<double> bound = Effective(overrides, *bound_spec);
    if (value && bound && *value > *bound) {
      return FieldError(Field(spec.name), absl::StrCat(FormatNumber(*value), " is above ",
                                                       spec.at_most, " = ", FormatNumber(*bound)));
    }
  }
  return absl::OkStatus();
}

}  // namespace scanprep
