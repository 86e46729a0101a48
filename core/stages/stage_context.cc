// SPDX-License-Identifier: Apache-2.0
#include "core/stages/stage_context.h"

#include <algorithm>

#include "absl/strings/str_cat.h"

namespace scanprep {
absl::StatusOr<Neighbourhoods*> StageContext::neighbourhoods() const {
  if (!shared_.neighbourhoods) {
    return absl::FailedPreconditionError(
        absl::StrCat("stage '", report_.name,
                     "' asked for the shared neighbourhoods, but its plan built none before it"));
  }
  return shared_.neighbourhoods.get();
}

bool StageContext::Ran(std::string_view name) const {
  return std::find(shared_.stages_run.begin(), shared_.stages_run.end(), name) !=
         shared_.stages_run.end();
}

}  // namespace scanprep
