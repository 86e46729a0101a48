// SPDX-License-Identifier: Apache-2.0
// Plain-text point lists (.xyz, .asc, .txt, .pts): reader and writer.
#pragma once

#include <filesystem>
#include <istream>
#include <ostream>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "core/base/point_cloud.h"
#include "core/io/cloud_writer.h"

namespace scanprep::io {

// One point per line: x y z separated by blanks or commas; further columns are left out with a
// warning, unless a comment line "# columns: NAME..." before the first point names them (as
// WriteXyz writes): then x, y, z, nx, ny, nz (all three or none), flags and scanline are read
// from the named columns and any other name is kept as an attribute, in the narrowest type that
// holds its values exactly. '#' starts a comment; blank lines are skipped. A first line
// holding a single integer is taken as a point count (Leica PTS) and checked. When profile_gap > 0
// the file order is taken as the scan order and a jump longer than profile_gap between consecutive
// points starts a new scanline; otherwise the cloud has no scanlines. Coordinates stay in the
// file's units. One scan, id = file stem; FinishLoading() has been called. A row with a NaN or
// infinite coordinate ("nan", "inf") is left out and counted in `warnings`; no point is an error
// (UnmeasuredPoints, as in every reader).
absl::StatusOr<PointCloud> ReadXyz(const std::filesystem::path& path,
                                   std::vector<std::string>& warnings, double profile_gap = 0.0);
absl::StatusOr<PointCloud> ReadXyz(std::istream& in, const std::string& name_for_errors,
                                   std::vector<std::string>& warnings, double profile_gap = 0.0);

// "# columns: x y z [nx ny nz] flags [scanline] [attributes]", then one point per line, floats
// to nine significant digits (read back exactly), attributes as their values (17 digits). Removed
// points are skipped unless include_removed.
absl::Status WriteXyz(const std::filesystem::path& path, const PointCloud& cloud,
                      const WriteOptions& options = {});
absl::Status WriteXyz(std::ostream& out, const PointCloud& cloud, const WriteOptions& options = {});

}  // namespace scanprep::io
