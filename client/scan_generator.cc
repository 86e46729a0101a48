// SPDX-License-Identifier: Apache-2.0
#include "client/scan_generator.h"

#include <map>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "core/sim/scan_simulator.h"

namespace scanprep::client {
namespace {

// Enough to give the outlier stage real work without dominating the scan.
constexpr double kSpikeFraction = 0.01;
constexpr size_t kMinPoints = 1'000;
constexpr size_t kMaxPoints = 20'000'000;

}  // namespace

std::vector<FlagSpec> GenerateFlags() {
  return {
      {"part", FlagSpec::kValue,
       "generated part: box (with a bore; default), plane, sphere, cylinder"},
      {"scans", FlagSpec::kValue, "generated scans: 1 (default) or 2 overlapping ones"},
      {"seed", FlagSpec::kValue, "seed of the generated noise and spikes (default 1)"},
  };
}

absl::StatusOr<GenerateOptions> ParseGenerateOptions(const ParsedArgs& args, size_t points) {
  GenerateOptions options{.points = points, .part = args.Get("part", "box")};
  const std::string scans = args.Get("scans", "1");
  if (scans != "1" && scans != "2") {
    return absl::InvalidArgumentError(absl::StrCat("--scans: '", scans, "' is neither 1 nor 2"));
  }
  options.scans = scans == "1" ? 1 : 2;
  if (args.Has("seed") && !absl::SimpleAtoi(args.Get("seed"), &options.seed)) {
    return absl::InvalidArgumentError(
        absl::StrCat("--seed: '", args.Get("seed"), "' is not a whole number >= 0"));
  }
  return options;
}

absl::StatusOr<PointCloud> GenerateScan(const GenerateOptions& options) {
  static const std::map<std::string, sim::Part> kParts = {{"box", sim::Part::kBoxWithBore},
                                                          {"plane", sim::Part::kPlane},
                                                          {"sphere", sim::Part::kSphere},
                                                          {"cylinder", sim::Part::kCylinder}};
  auto part = kParts.find(options.part);
  if (part == kParts.end()) {
    return absl::InvalidArgumentError(
        absl::StrCat("unknown part '", options.part, "' (use box, plane, sphere or cylinder)"));
  }
  if (options.points < kMinPoints || options.points > kMaxPoints) {
    return absl::InvalidArgumentError(absl::StrCat("points: ", options.points, " is outside [",
                                                   kMinPoints, ", ", kMaxPoints, "]"));
  }
  const std::vector<sim::SimSensor> sensors = options.scans == 2
                                                  ? sim::TwoOverlappingSensors(part->second)
                                                  : sim::FrontalSensor(part->second);
  return sim::SimulateWithPointCount(part->second, sensors, options.points, kSpikeFraction,
                                     options.seed)
      .cloud;
}

}  // namespace scanprep::client
