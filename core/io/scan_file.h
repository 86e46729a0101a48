// SPDX-License-Identifier: Apache-2.0
// Reads and writes a scan in any supported format: a file's by its extension, a stream's (standard
// input and output) as named.
#pragma once

#include <filesystem>
#include <istream>
#include <ostream>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "core/base/point_cloud.h"
#include "core/io/cloud_writer.h"

namespace scanprep::io {

enum class ScanFormat { kPly, kPcd, kE57, kLas, kXyz };

// "ply", "pcd", "e57", "las" (and "laz", refused when read), "xyz" (also "asc", "txt", "pts"),
// case-insensitive; INVALID_ARGUMENT
// naming the choices otherwise.
absl::StatusOr<ScanFormat> ParseScanFormat(std::string_view name);
// By extension: .ply, .pcd, .e57, .las/.laz, .xyz/.asc/.txt/.pts; INVALID_ARGUMENT naming the
// supported ones.
absl::StatusOr<ScanFormat> ScanFormatOf(const std::filesystem::path& path);
// Whether WriteScanFile/WriteScanStream can write `format` (PLY, PCD, LAS and XYZ; E57 is read
// only).
bool Writable(ScanFormat format);
// The names of `attributes` the writer of `format` has no place for: none for PLY, PCD, XYZ (they
// store any name), those LasKeeps leaves out for LAS.
std::vector<std::string> AttributesLeftOut(ScanFormat format,
                                           const std::vector<PointAttribute>& attributes);
// The format WriteScanFile writes `path` in: .ply, .pcd, .las, .xyz/.asc/.txt; INVALID_ARGUMENT for
// any other extension (.pts, .laz, a read-only format) naming the written ones.
absl::StatusOr<ScanFormat> WritableFormatOf(const std::filesystem::path& path);

struct ReadOptions {
  // Text files without a scanline column: a jump longer than this (file units) between
  // consecutive points starts a new scanline (ReadXyz); 0 = no scanlines. Binary formats
  // carry their own scanline structure and are read as they are.
  double profile_gap = 0;
};

// ReadPly, ReadPcd, ReadE57, ReadLas or ReadXyz by the file's extension (ScanFormatOf). What a
// reader could not use or had to leave out is appended to `warnings`.
absl::StatusOr<PointCloud> ReadScanFile(const std::filesystem::path& path,
                                        std::vector<std::string>& warnings,
                                        const ReadOptions& options = {});
absl::StatusOr<PointCloud> ReadScanStream(std::istream& in, ScanFormat format,
                                          const std::string& name_for_errors,
                                          std::vector<std::string>& warnings,
                                          const ReadOptions& options = {});

// WritePly (binary), WritePcd (binary), WriteLas or WriteXyz (text) by the file's extension (.ply,
// .pcd, .las, .xyz/.asc/.txt); INVALID_ARGUMENT for any other, before anything is written.
absl::Status WriteScanFile(const std::filesystem::path& path, const PointCloud& cloud,
                           const WriteOptions& options = {});
absl::Status WriteScanStream(std::ostream& out, ScanFormat format, const PointCloud& cloud,
                             const WriteOptions& options = {});

}  // namespace scanprep::io
