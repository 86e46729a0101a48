// Named pipeline parameters: each is derived from the data by default, may be overridden by the
// request, and is always reported with the value actually used.
#pragma once

#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"

namespace scanprep {

struct ParamSpec {
  std::string name;         // "<stage>.<param>", e.g. "smoothing.lambda"
  std::string description;  // what it is and how its default is derived
  std::string default_text; // the default, or the rule that derives it
  std::vector<std::string> choices;  // non-empty for a choice parameter, else numeric
};

using ParamOverrides = std::map<std::string, std::string, std::less<>>;

// Checks every override against the specs: the name must exist, a numeric value must parse as a
// finite number, a choice must be one of its choices.
absl::Status ValidateOverrides(const ParamOverrides& overrides, const std::vector<ParamSpec>& specs);

}  // namespace scanprep
