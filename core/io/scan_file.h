// SPDX-License-Identifier: Apache-2.0
// Reads and writes a scan file of any supported format, chosen by extension.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "core/io/cloud_writer.h"
#include "core/point_cloud.h"

namespace scanprep::io {

struct ReadOptions {
  // Text files without a scanline column: a jump longer than this (file units) between
  // consecutive points starts a new scanline (ReadXyz); 0 = no scanlines. Binary formats
  // carry their own scanline structure and are read as they are.
  double profile_gap = 0;
};

// .ply -> ReadPly; .pcd -> ReadPcd; .e57 -> ReadE57; .xyz/.asc/.txt/.pts -> ReadXyz. Extensions are
// case-insensitive. What a reader could not use or had to leave out is appended to `warnings`.
absl::StatusOr<PointCloud> ReadScanFile(const std::filesystem::path& path,
                                        std::vector<std::string>& warnings,
                                        const ReadOptions& options = {});

// .ply -> WritePly (binary), .pcd -> WritePcd (binary), .xyz/.asc/.txt -> WriteXyz (text);
// INVALID_ARGUMENT for any other extension, before anything is written.
absl::Status WriteScanFile(const std::filesystem::path& path, const PointCloud& cloud,
                           const WriteOptions& options = {});

}  // namespace scanprep::io
