// SPDX-License-Identifier: Apache-2.0
// PCD (Point Cloud Library) reader and writer.
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

// Reads PCD 0.6 and 0.7 files as PCL writes them: DATA ascii, binary (little-endian records) and
// binary_compressed (LZF, fields stored one after another). FIELDS x y z of any TYPE/SIZE are
// required; normal_x/y/z -> normals, intensity -> intensity, and the fields WritePcd adds: flags
// (U1) -> flags, scanline (U4) -> scanline (an organised cloud's rows win). Every other field
// of one value up to 4 bytes, or F8 (rgb, rgba, curvature, ...), is kept as an attribute in its
// own type; the rest (COUNT > 1, 8-byte integers, a flags or scanline of another type) is read
// past and named in a warning; PCL's "_" padding fields are skipped.
//
// Points with a NaN or infinite coordinate are PCL's mark for "no measurement" in organised
// clouds: they are left out and counted in a warning, as the service does with such points (a
// file with no valid point at all is an error). An organised cloud (HEIGHT > 1) gets scanline =
// image row, like a PLY range_grid; the points of a row stay in column order.
//
// VIEWPOINT tx ty tz qw qx qy qz is PCL's sensor_origin_/sensor_orientation_: the acquisition
// pose expressed in the frame the points are already in (PCL never applies it to the points). The
// translation becomes the scan's camera_position, in the file's frame and units; the orientation
// is not needed (the measures use the camera centre only). PCL writes 0 0 0 1 0 0 0 whenever the
// pose is unknown, so that exact value (or no VIEWPOINT line) leaves camera_position empty, with
// a warning saying how to give the origin. Coordinates stay in the file's units; one scan, id =
// file stem; FinishLoading() has been called. Warnings are appended to `warnings`.
absl::StatusOr<PointCloud> ReadPcd(const std::filesystem::path& path,
                                   std::vector<std::string>& warnings);
absl::StatusOr<PointCloud> ReadPcd(std::istream& in, const std::string& name_for_errors,
                                   std::vector<std::string>& warnings);

// PCD 0.7, DATA binary, one unorganised row: x y z float; normal_x/y/z when the cloud has normals;
// intensity when present; flags U1; scanline U4 when present; each attribute in its own
// TYPE/SIZE. Removed points are skipped unless include_removed.
absl::Status WritePcd(const std::filesystem::path& path, const PointCloud& cloud,
                      const WriteOptions& options = {});
absl::Status WritePcd(std::ostream& out, const PointCloud& cloud, const WriteOptions& options = {});

}  // namespace scanprep::io
