// SPDX-License-Identifier: Apache-2.0
// Plain-text point list writer: a "# columns:" line naming the columns, then one point per line.
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "core/base/status_macros.h"
#include "core/io/cloud_writer.h"
#include "core/io/xyz.h"

namespace scanprep::io {

absl::Status WriteXyz(std::ostream& out, const PointCloud& cloud, const WriteOptions& options) {
  SCANPREP_RETURN_IF_ERROR(CheckWritable(cloud, "XYZ"));
  SCANPREP_RETURN_IF_ERROR(
      CheckAttributeNames(cloud, "XYZ", {"x", "y", "z", "nx", "ny", "nz", "flags", "scanline"}));
  const bool normals = cloud.has_normals(), scanlines = cloud.has_scanlines();
  std::vector<std::string> names = {"x", "y", "z"};
  if (normals) names.insert(names.end(), {"nx", "ny", "nz"});
  names.push_back("flags");
  if (scanlines) names.push_back("scanline");
  for (const PointAttribute& a : cloud.attributes) names.push_back(a.name);
  out << "# written by scanprep\n# columns: " << absl::StrJoin(names, " ") << "\n";
  std::string line;
  for (size_t i = 0; i < cloud.size() && out; ++i) {
    if (!Written(cloud, i, options)) continue;
    // %.9g: nine significant digits read back as the same float; %.17g the same double.
    if (WritesDoubleCoordinates(cloud)) {
      const Eigen::Vector3d p = WorldPoint(cloud, i);
      line = absl::StrFormat("%.17g %.17g %.17g", p.x(), p.y(), p.z());
    } else {
      line = absl::StrFormat("%.9g %.9g %.9g", cloud.x[i], cloud.y[i], cloud.z[i]);
    }
    if (normals)
      absl::StrAppendFormat(&line, " %.9g %.9g %.9g", cloud.nx[i], cloud.ny[i], cloud.nz[i]);
    absl::StrAppend(&line, " ", cloud.flags.empty() ? 0 : cloud.flags[i]);
    if (scanlines) absl::StrAppend(&line, " ", cloud.scanline[i]);
    for (const PointAttribute& a : cloud.attributes) {
      if (a.type == AttributeType::kFloat32) {
        absl::StrAppendFormat(&line, " %.9g", a.Value(i));
      } else {
        absl::StrAppendFormat(&line, " %.17g", a.Value(i));
      }
    }
    line += '\n';
    out.write(line.data(), static_cast<std::streamsize>(line.size()));
  }
  if (!out) return absl::UnavailableError("cannot write XYZ: output stream failed");
  return absl::OkStatus();
}

absl::Status WriteXyz(const std::filesystem::path& path, const PointCloud& cloud,
                      const WriteOptions& options) {
  return WriteFile(path, [&](std::ostream& out) { return WriteXyz(out, cloud, options); });
}

}  // namespace scanprep::io
