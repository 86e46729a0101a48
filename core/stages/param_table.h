// SPDX-License-Identifier: Apache-2.0
// A stage's parameters, declared once. Each line of a stage's table binds a field of its settings
// struct to the parameter's name, default, range and description (as PDAL's `args.add`); the
// spec (validation, GetInfo, `scanprep info`, the docs table), the reader and the report entry
// all come from that line. A stage reads its parameters only as its settings, so it cannot read
// one its table does not declare.
#pragma once

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <functional>
#include <initializer_list>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "absl/strings/numbers.h"
#include "core/stages/params.h"
#include "core/stages/report.h"

namespace scanprep {

// A parameter whose default the stage derives from the data: the request's value, if it set
// one. The stage records the value it used under `name` (per scan where it derives one per scan).
template <typename T>
struct Derived {
  std::optional<T> forced;
  std::string name;

  T Or(T derived) const { return forced.value_or(derived); }
};

// One line of a table: the spec, and how the value reaches the settings and the report.
template <typename Settings>
struct Param {
  ParamSpec spec;
  // Sets the field from `value`: the override's number (validated before the job started) or
  // the default; for a choice, the index of the chosen value. Derived ones get nullopt when the
  // request did not set them.
  std::function<void(std::optional<double> value, Settings&)> set;
  // The bound field's address in `settings`: how Name() finds a field's line.
  std::function<const void*(const Settings&)> field;
  // Whether the parameter takes part in a job with these settings (e.g. a method's own
  // parameters only when the method is chosen); one that does not is not reported.
  std::function<bool(const Settings&)> applies;

  // The parameter applies only when `predicate` holds.
  Param When(std::function<bool(const Settings&)> predicate) && {
    applies = std::move(predicate);
    return std::move(*this);
  }
  // The parameter may not exceed the integer parameter `other` (ValidateOverrides).
  Param AtMost(std::string_view other) && {
    spec.at_most = std::string(other);
    return std::move(*this);
  }
};

template <typename Settings>
class ParamTable {
 public:
  ParamTable(std::initializer_list<Param<Settings>> params) : params_(params) {}

  std::vector<ParamSpec> Specs() const {
    std::vector<ParamSpec> specs;
    for (const Param<Settings>& p : params_) specs.push_back(p.spec);
    return specs;
  }

  // The name declared for `field`, for code that refers to a parameter from outside its stage
  // (a preset, another parameter's bound, the server's sizing). Aborts for a field the table
  // does not bind: a programming error, caught by any test that runs the caller.
  template <typename T>
  const std::string& Name(T Settings::*field) const {
    return LineOf(field).spec.name;
  }

  // The override that sets `field` to `value`, as a preset or a request would write it.
  template <typename T>
  std::pair<const std::string, std::string> Override(T Settings::*field, T value) const {
    const ParamSpec& spec = LineOf(field).spec;
    if (spec.kind == ParamKind::kChoice)
      return {spec.name, spec.choices[static_cast<size_t>(value)]};
    return {spec.name, FormatNumber(static_cast<double>(value))};
  }

  // The settings of a job with these (validated) overrides; records nothing, so planning can
  // read them before any stage runs.
  Settings Read(const ParamOverrides& overrides) const {
    Settings settings{};
    for (const Param<Settings>& p : params_) p.set(ValueOf(p.spec, overrides), settings);
    return settings;
  }

  // Records, in `report`, every parameter with a fixed default that applies to `settings`, with
  // the value used: a number as the request's text reads (the double, not the field's narrower
  // type), a choice as its text. Derived ones are the stage's to record.
  // With `only`, just the parameters named there.
  void Record(const ParamOverrides& overrides, const Settings& settings, StageReport& report,
              const std::vector<std::string>& only = {}) const {
    for (const Param<Settings>& p : params_) {
      if (p.applies && !p.applies(settings)) continue;
      if (!only.empty() && std::find(only.begin(), only.end(), p.spec.name) == only.end()) continue;
      const ParamSpec& spec = p.spec;
      if (spec.kind == ParamKind::kChoice) {
        report.text_parameters[spec.name] = spec.choices[ChoiceIndex(spec, overrides)];
      } else if (spec.default_value.has_value()) {
        report.parameters[spec.name] = *ValueOf(spec, overrides);
      }
    }
  }

 private:
  // The line that binds `field`; aborts for one the table does not bind (see Name).
  template <typename T>
  const Param<Settings>& LineOf(T Settings::*field) const {
    static const Settings probe{};
    for (const Param<Settings>& p : params_) {
      if (p.field(probe) == &(probe.*field)) return p;
    }
    std::abort();
  }

  static size_t ChoiceIndex(const ParamSpec& spec, const ParamOverrides& overrides) {
    const auto it = overrides.find(spec.name);
    if (it == overrides.end()) return 0;
    size_t i = 0;
    while (i + 1 < spec.choices.size() && spec.choices[i] != it->second) ++i;
    return i;
  }

  static std::optional<double> ValueOf(const ParamSpec& spec, const ParamOverrides& overrides) {
    if (spec.kind == ParamKind::kChoice) return static_cast<double>(ChoiceIndex(spec, overrides));
    const auto it = overrides.find(spec.name);
    double value = 0;
    if (it != overrides.end() && absl::SimpleAtod(it->second, &value)) return value;
    return spec.default_value;
  }

  std::vector<Param<Settings>> params_;
};

// The lines of a table, one per parameter: the settings field first, then the name, the
// default (or the rule that derives it), the range and the description.
namespace param {
namespace internal {

// A line binding `field` to `spec`; set(value, field) stores the value.
template <typename S, typename T, typename Set>
Param<S> Bind(ParamSpec spec, T S::*field, Set set) {
  return {std::move(spec), [field, set](std::optional<double> v, S& s) { set(v, s.*field); },
          [field](const S& s) -> const void* { return &(s.*field); }};
}

// A fixed default's value (or a choice's index) into the field's type. In range (validated), so
// the conversion is exact for integers.
template <typename T>
void Store(std::optional<double> value, T& field) {
  field = static_cast<T>(*value);
}

// A derived one: the name to record it under, and the request's value if it set one.
template <typename T>
auto StoreDerived(std::string_view name) {
  return [name = std::string(name)](std::optional<double> value, Derived<T>& field) {
    field.name = name;
    if (value) field.forced = static_cast<T>(*value);
  };
}

}  // namespace internal

template <typename S, typename T>
Param<S> Real(T S::*field, std::string_view name, double default_value, ParamRange range,
              std::string description) {
  return internal::Bind(RealParam(name, std::move(description), default_value, range), field,
                        internal::Store<T>);
}

template <typename S, typename T>
Param<S> Integer(T S::*field, std::string_view name, int64_t default_value, ParamRange range,
                 std::string description) {
  return internal::Bind(IntegerParam(name, std::move(description), default_value, range), field,
                        internal::Store<T>);
}

template <typename S, typename T>
Param<S> DerivedReal(Derived<T> S::*field, std::string_view name, std::string rule,
                     ParamRange range, std::string description) {
  return internal::Bind(DerivedRealParam(name, std::move(description), std::move(rule), range),
                        field, internal::StoreDerived<T>(name));
}

template <typename S, typename T>
Param<S> DerivedInteger(Derived<T> S::*field, std::string_view name, std::string rule,
                        ParamRange range, std::string description) {
  return internal::Bind(DerivedIntegerParam(name, std::move(description), std::move(rule), range),
                        field, internal::StoreDerived<T>(name));
}

// `values` in the order of the enum E; the first is the default.
template <typename S, typename E>
Param<S> Choice(E S::*field, std::string_view name, std::vector<std::string> values,
                std::string description) {
  return internal::Bind(ChoiceParam(name, std::move(description), std::move(values)), field,
                        internal::Store<E>);
}

}  // namespace param
}  // namespace scanprep
