#include "core/params.h"

#include <algorithm>
#include <cmath>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"

namespace scanprep {

absl::Status ValidateOverrides(const ParamOverrides& overrides, const std::vector<ParamSpec>& specs) {
  for (const auto& override : overrides) {
    // Plain references, not a structured binding: clang < 16 cannot capture bindings in lambdas.
    const std::string& name = override.first;
    const std::string& value = override.second;
    auto spec = std::find_if(specs.begin(), specs.end(),
                             [&](const ParamSpec& s) { return s.name == name; });
    if (spec == specs.end()) {
      return absl::InvalidArgumentError(
          absl::StrCat("options.params: unknown parameter '", name, "'"));
    }
    if (!spec->choices.empty()) {
      if (std::find(spec->choices.begin(), spec->choices.end(), value) == spec->choices.end()) {
        return absl::InvalidArgumentError(absl::StrCat("options.params['", name, "']: '", value,
                                                       "' is not one of ",
                                                       absl::StrJoin(spec->choices, ", ")));
      }
      continue;
    }
    double number = 0;
    if (!absl::SimpleAtod(value, &number) || !std::isfinite(number)) {
      return absl::InvalidArgumentError(
          absl::StrCat("options.params['", name, "']: '", value, "' is not a finite number"));
    }
  }
  return absl::OkStatus();
}

}  // namespace scanprep
