// SPDX-License-Identifier: Apache-2.0
// ASTM E57 (E2807) reader: the format metrology and terrestrial scanners export.
#pragma once

#include <cstdint>
#include <filesystem>
#include <istream>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "core/base/point_cloud.h"

namespace scanprep::io {

// Every data3D entry of the file becomes one scan (cloud.scan = its index, in file order; id =
// its name, or "data3D N" without one). Coordinates: cartesianX/Y/Z, or sphericalRange/Azimuth/
// Elevation converted to cartesian, then moved by the scan's pose (rotation quaternion and
// translation) into the file's frame; the pose's translation is the scan's camera_position
// (E57's scanner origin). E57 is metres by definition; the coordinates stay as they are, and
// the caller states the unit. Points and poses are combined in double and stored relative to a
// round origin near the data (WideCoordinates, cloud.origin; camera positions too), so a
// georeferenced scan keeps its precision. Points whose cartesian/spherical invalid state is not 0
// (no measurement, or a direction only) are left out and counted in a warning, like PCD's NaN
// points. intensity -> intensity when every scan has it. A scan with rowIndex and columnIndex is
// a grid: its scanlines are the index that changes least often along the records (a scanner
// writes a line at a time), points of a line in the order of the other index.
//
// Fields are decoded as the standard's bitPackCodec stores them (Float single and double,
// Integer and ScaledInteger bit-packed between their minimum and maximum); other codecs,
// String fields and damaged pages (CRC-32C) are INVALID_ARGUMENT naming the scan, field or page.
// Every size is checked against the file before anything is allocated for it. Fields the
// service has no use for (colour, returns, time stamps) are kept as attributes for the output,
// in the type their prototype bounds, when every scan has them alike; the others are named in a
// warning.
// The CRC-32C (Castagnoli) an E57 page carries over its payload, stored big-endian in the page's
// last four bytes.
uint32_t E57PageChecksum(std::string_view payload);

absl::StatusOr<PointCloud> ReadE57(const std::filesystem::path& path,
                                   std::vector<std::string>& warnings);
absl::StatusOr<PointCloud> ReadE57(std::istream& in, const std::string& name_for_errors,
                                   std::vector<std::string>& warnings);
absl::StatusOr<PointCloud> ReadE57Bytes(std::string_view file, const std::string& name_for_errors,
                                        std::vector<std::string>& warnings);

}  // namespace scanprep::io
