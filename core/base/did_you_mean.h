// SPDX-License-Identifier: Apache-2.0
// "did you mean ...?" for a name that is not one of the known ones (a parameter, a stage, a
// preset): a typo should cost one look at the message, not a trip to the manual.
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace scanprep {

// The known name closest to `name` by edit distance (insertions, deletions, substitutions and
// swaps of neighbours, each 1), if it is within a third of the longer name's length (at least
// 1): a near miss, not any name at all. Ties go to the first in `known`. Empty when none is near.
std::string ClosestName(std::string_view name, const std::vector<std::string>& known);

// " (did you mean 'x'?)" for ClosestName's answer, or "" when there is none: appended to an
// "unknown ..." message.
std::string DidYouMean(std::string_view name, const std::vector<std::string>& known);

}  // namespace scanprep
