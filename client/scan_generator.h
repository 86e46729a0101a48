// SPDX-License-Identifier: Apache-2.0
// Generated laser-line scans for `scanprep simulate` and `scanprep load --simulate`: an analytic
// part scanned by core/sim's simulated sensor, its spacings scaled to give about the requested
// number of points.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "absl/status/statusor.h"
#include "client/cli_args.h"
#include "core/base/point_cloud.h"

namespace scanprep::client {

struct GenerateOptions {
  size_t points = 0;
  std::string part = "box";  // box, plane, sphere or cylinder
  int scans = 1;             // 1: the frontal sensor; 2: plus an oblique, noisier one
  uint64_t seed = 1;
};

// The flags the generator reads (--part, --scans, --seed), shared by the two commands.
std::vector<FlagSpec> GenerateFlags();
// GenerateOptions from those flags and `points`.
absl::StatusOr<GenerateOptions> ParseGenerateOptions(const ParsedArgs& args, size_t points);

// Millimetres, common frame, one ScanMeta per sensor (camera position, laser direction,
// scanline and point spacing, uncertainty), scanlines set, 1 % spikes.
absl::StatusOr<PointCloud> GenerateScan(const GenerateOptions& options);

}  // namespace scanprep::client
