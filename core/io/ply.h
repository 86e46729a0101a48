// SPDX-License-Identifier: Apache-2.0
// PLY point-cloud reader and writer.
#pragma once

#include <filesystem>
#include <istream>
#include <ostream>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/base/point_cloud.h"
#include "core/io/cloud_writer.h"

namespace scanprep::io {

// Reads ASCII, binary_little_endian and binary_big_endian PLY. Vertex x,y,z of any scalar type.
// Optional vertex properties: nx,ny,nz -> normals; "intensity" -> intensity; "confidence" or
// "quality" -> quality (clamped to [0,1]); "scan"/"scan_index" -> scan; "scanline" -> scanline;
// "flags" -> flags (as written by WritePly). Every other scalar vertex property is kept as an
// attribute in its own type (colour, a scanner's fields); vertex list properties are named in a
// warning; other elements, comment and obj_info lines are skipped. A Stanford `range_grid` element
// (list vertex_indices, num_cols from obj_info) gives each vertex its scanline = grid row
// (row-major: entry index = row*num_cols + col); it must list every vertex once, in vertex order.
// Coordinates stay in the file's units. A vertex with a NaN or infinite coordinate is a
// scanner's "no measurement" (an organised cloud's hole): it is left out and counted in a warning,
// as the PCD reader and the service do with such points. Scan ids are the file stem (suffixed
// ":<k>" when the file carries several scans); FinishLoading() has been called.
absl::StatusOr<PointCloud> ReadPly(const std::filesystem::path& path,
                                   std::vector<std::string>& warnings);
absl::StatusOr<PointCloud> ReadPly(std::istream& in, const std::string& name_for_errors,
                                   std::vector<std::string>& warnings);

// Binary little-endian PLY: x,y,z float; nx,ny,nz float when the cloud has normals; flags uchar;
// scan uint; scanline uint when present; quality, intensity float when present; then each
// attribute in its own type. Removed points are
// skipped unless include_removed.
absl::Status WritePly(const std::filesystem::path& path, const PointCloud& cloud,
                      const WriteOptions& options = {});
absl::Status WritePly(std::ostream& out, const PointCloud& cloud, const WriteOptions& options = {});

}  // namespace scanprep::io
