// SPDX-License-Identifier: Apache-2.0
// Named pipeline parameters: each is declared once by its stage's ParamTable (kind, default, valid
// range), may be overridden by the request, is range-checked before any stage runs, and is always
// reported with the value actually used.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "absl/status/status.h"

namespace scanprep {

enum class ParamKind { kReal, kInteger, kChoice };

// The admissible values of a numeric parameter: an interval with inclusive or exclusive ends.
struct ParamRange {
  double min = 0;
  double max = 0;
  bool min_inclusive = true;
  bool max_inclusive = true;

  bool Contains(double value) const;
  std::string ToString() const;  // "[1, 1000]", "(0, 10000]"
};

ParamRange Closed(double min, double max);     // [min, max]
ParamRange LeftOpen(double min, double max);   // (min, max]
ParamRange RightOpen(double min, double max);  // [min, max)
ParamRange Open(double min, double max);       // (min, max)

struct ParamSpec {
  std::string name;  // "<stage>.<param>", e.g. "smoothing.lambda"
  ParamKind kind = ParamKind::kReal;
  std::string description;
  // The numeric default; none when the default is derived from the data (default_text says how).
  std::optional<double> default_value;
  std::string default_text;          // the default as shown: the number, the choice or the rule
  ParamRange range;                  // numeric kinds
  std::vector<std::string> choices;  // kChoice; the first is the default
  // Another integer parameter this one may not exceed (a subset of the shared k-NN graph).
  std::string at_most;
};

// The specs a stage's ParamTable builds, one per line of it (core/stages/param_table.h).
ParamSpec RealParam(std::string_view name, std::string description, double default_value,
                    ParamRange range);
ParamSpec DerivedRealParam(std::string_view name, std::string description, std::string rule,
                           ParamRange range);
ParamSpec IntegerParam(std::string_view name, std::string description, int64_t default_value,
                       ParamRange range);
ParamSpec DerivedIntegerParam(std::string_view name, std::string description, std::string rule,
                              ParamRange range);
ParamSpec ChoiceParam(std::string_view name, std::string description,
                      std::vector<std::string> choices);

// The shortest text that reads back as `value` ("1e+30", "0.05", "4294967296").
std::string FormatNumber(double value);

using ParamOverrides = std::map<std::string, std::string, std::less<>>;

// Checks every override against the specs before any work: the name must exist; a choice must be
// one of its choices; a number must parse, be finite, be whole for an integer parameter, lie in
// the range and not exceed its `at_most` parameter. Integers are checked as doubles, so no
// out-of-range value is ever converted.
absl::Status ValidateOverrides(const ParamOverrides& overrides,
                               const std::vector<ParamSpec>& specs);

}  // namespace scanprep
