// SPDX-License-Identifier: Apache-2.0
// Reads a scan file of any supported format, chosen by extension.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "core/point_cloud.h"

namespace scanprep::io {

// .ply -> ReadPly; .pcd -> ReadPcd; .xyz/.asc/.txt/.pts -> ReadXyz (no scanlines). Extensions are
// case-insensitive. What a reader could not use or had to leave out is appended to `warnings`.
absl::StatusOr<PointCloud> ReadScanFile(const std::filesystem::path& path,
                                        std::vector<std::string>& warnings);

}  // namespace scanprep::io
