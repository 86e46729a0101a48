// Reads a scan file of any supported format, chosen by extension.
#pragma once

#include <filesystem>

#include "absl/status/statusor.h"
#include "core/point_cloud.h"

namespace scanprep::io {

// .ply -> ReadPly; .xyz/.asc/.txt/.pts -> ReadXyz (no scanlines). Extensions are case-insensitive.
absl::StatusOr<PointCloud> ReadScanFile(const std::filesystem::path& path);

}  // namespace scanprep::io
