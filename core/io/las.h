// SPDX-License-Identifier: Apache-2.0
// LAS (ASPRS) reader and writer: what line and mobile scanners and PDAL write.
#pragma once

#include <filesystem>
#include <istream>
#include <ostream>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/base/point_cloud.h"
#include "core/io/cloud_writer.h"

namespace scanprep::io {

// LAS 1.0 to 1.4, point data record formats 0 to 10: X, Y, Z as scaled integers (x = X * scale +
// offset, in the file's units), in double relative to the cloud's origin (LocalOrigin of the
// records' box), so a georeferenced file keeps every coordinate within half a unit of its scale
// (INVALID_ARGUMENT naming the point where float cannot); intensity -> intensity. The scan
// structure: a new scanline starts where the scan direction flag changes or after a point on the
// edge of the flight line (the last of its line; an edge point that is the first of its line, as
// some scanners also mark, ends nothing); a file with a single line gets none. The scan angle is
// read and its range given in a warning (it is not a per-point value of the service). Colour and
// GPS time, where the format has them, become the attributes red, green, blue (uint16) and
// gps_time (float64). What is not kept (classification, returns, scan angle, extra bytes) is
// named in a warning. Variable-length records are skipped by
// the header's offset. Compressed LAZ (point format with bit 7 or 6 set, or a .laz name) is
// INVALID_ARGUMENT naming a way to decompress it: no LASzip decoder is packaged for Debian 12.
// Counts, offsets and record lengths are checked against the file before anything is allocated, and
// records the header's count leaves out are refused like PLY's and PCD's. One scan, id = file stem,
// no sensor origin (LAS has none; a warning says how to give one); cloud.grid is the header's
// scale and offset; FinishLoading() has been called.
absl::StatusOr<PointCloud> ReadLas(const std::filesystem::path& path,
                                   std::vector<std::string>& warnings);
absl::StatusOr<PointCloud> ReadLas(std::istream& in, const std::string& name_for_errors,
                                   std::vector<std::string>& warnings);
absl::StatusOr<PointCloud> ReadLasBytes(std::string_view file, const std::string& name_for_errors,
                                        std::vector<std::string>& warnings);

// LAS 1.2, point data format 0, or 1, 2, 3 when the cloud has the attributes LAS has a place for
// (LasKeeps: gps_time; red, green, blue together, integers of up to 16 bits, 8-bit ones scaled by
// 256 as the format asks), no variable-length records. X, Y, Z on cloud.grid (the file the
// points were read from: a point nothing moved gets its own integer back), else on a grid of
// 1/1000 of the unit (1 µm in mm) offset by the cloud's origin rounded to a whole unit;
// INVALID_ARGUMENT naming the point and value when a coordinate is beyond a 32-bit integer of that
// grid. Intensity when the cloud has it (INVALID_ARGUMENT for a value that is not an integer in 0
// to 65535), scanprep's flags in the user data byte and classification 7 (noise) for removed points
// (written with include_removed, else left out), the scan index as point source ID, and the scan
// direction flag turned at each new scanline so that ReadLas finds the same lines. Normals,
// quality and other attributes: LAS 1.2 has no field for them.
// The names of `attributes` that WriteLas keeps; the others have no place in LAS 1.2.
std::vector<std::string> LasKeeps(const std::vector<PointAttribute>& attributes);

absl::Status WriteLas(const std::filesystem::path& path, const PointCloud& cloud,
                      const WriteOptions& options = {});
absl::Status WriteLas(std::ostream& out, const PointCloud& cloud, const WriteOptions& options = {});

}  // namespace scanprep::io
