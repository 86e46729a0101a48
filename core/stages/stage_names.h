// SPDX-License-Identifier: Apache-2.0
// Every stage's name, written once: its StageInfo, the prerequisites that name it, the default
// plan and the checks of which stages ran refer to these.
#pragma once

#include <initializer_list>
#include <string>
#include <string_view>
#include <vector>

namespace scanprep::stage_names {

inline constexpr std::string_view kNeighbourhoods = "neighbourhoods";
inline constexpr std::string_view kOutliers = "outliers";
inline constexpr std::string_view kSurfaceSpikes = "surface_spikes";  // internal: after LoOP
inline constexpr std::string_view kNormals = "normals";
inline constexpr std::string_view kMeasures = "measures";
inline constexpr std::string_view kRegistration = "registration";
inline constexpr std::string_view kCorrection = "correction";
inline constexpr std::string_view kHealth = "health";
inline constexpr std::string_view kSmoothing = "smoothing";
inline constexpr std::string_view kSimplification = "simplification";

// `names` as a plan lists them (StageInfo::prerequisites, followers).
inline std::vector<std::string> List(std::initializer_list<std::string_view> names) {
  return {names.begin(), names.end()};
}

}  // namespace scanprep::stage_names
