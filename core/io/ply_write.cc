// SPDX-License-Identifier: Apache-2.0
// Binary little-endian PLY writer, packing the structure-of-arrays cloud in fixed-size chunks.
#include <algorithm>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "core/base/status_macros.h"
#include "core/io/byte_order.h"
#include "core/io/cloud_writer.h"
#include "core/io/ply.h"
#include "core/io/ply_header.h"

namespace scanprep::io {
namespace {

class RecordPacker {
 public:
  explicit RecordPacker(std::vector<char>& buffer) : buffer_(buffer) {}
  template <class T>
  void Put(T value) {
    if constexpr (kHostIsBigEndian) value = ByteSwapped(value);
    const size_t at = buffer_.size();
    buffer_.resize(at + sizeof(T));
    std::memcpy(buffer_.data() + at, &value, sizeof(T));
  }

 private:
  std::vector<char>& buffer_;
};

}  // namespace

absl::Status WritePly(std::ostream& out, const PointCloud& cloud, const WriteOptions& options) {
  SCANPREP_RETURN_IF_ERROR(CheckWritable(cloud, "PLY"));
  SCANPREP_RETURN_IF_ERROR(CheckAttributeNames(
      cloud, "PLY",
      {"x", "y", "z", "nx", "ny", "nz", "flags", "scan", "scanline", "quality", "intensity"}));
  const size_t n = cloud.size();
  const size_t count = WrittenCount(cloud, options);

  const bool wide = WritesDoubleCoordinates(cloud);
  const char* coordinate = wide ? "double" : "float";
  std::string header =
      absl::StrCat("ply\nformat binary_little_endian 1.0\ncomment written by scanprep\n",
                   "element vertex ", count, "\n", "property ", coordinate, " x\nproperty ",
                   coordinate, " y\nproperty ", coordinate, " z\n");
  if (cloud.has_normals())
    absl::StrAppend(&header, "property float nx\nproperty float ny\nproperty float nz\n");
  absl::StrAppend(&header, "property uchar flags\nproperty uint scan\n");
  if (cloud.has_scanlines()) absl::StrAppend(&header, "property uint scanline\n");
  if (!cloud.quality.empty()) absl::StrAppend(&header, "property float quality\n");
  if (!cloud.intensity.empty()) absl::StrAppend(&header, "property float intensity\n");
  for (const PointAttribute& attribute : cloud.attributes) {
    absl::StrAppend(&header, "property ", ply::TypeName(attribute.type), " ", attribute.name, "\n");
  }
  absl::StrAppend(&header, "end_header\n");
  out.write(header.data(), static_cast<std::streamsize>(header.size()));

  constexpr size_t kChunkPoints = 1 << 16;
  std::vector<char> buffer;
  buffer.reserve(kChunkPoints * 52);  // the widest record without attributes is 50 bytes
  RecordPacker pack(buffer);
  for (size_t begin = 0; begin < n && out; begin += kChunkPoints) {
    buffer.clear();
    for (size_t i = begin; i < std::min(n, begin + kChunkPoints); ++i) {
      if (!Written(cloud, i, options)) continue;
      if (wide) {
        const Eigen::Vector3d p = WorldPoint(cloud, i);
        pack.Put(p.x()), pack.Put(p.y()), pack.Put(p.z());
      } else {
        pack.Put(cloud.x[i]), pack.Put(cloud.y[i]), pack.Put(cloud.z[i]);
      }
      if (cloud.has_normals()) {
        pack.Put(cloud.nx[i]);
        pack.Put(cloud.ny[i]);
        pack.Put(cloud.nz[i]);
      }
      pack.Put(cloud.flags.empty() ? uint8_t{0} : cloud.flags[i]);
      pack.Put(cloud.scan.empty() ? uint32_t{0} : cloud.scan[i]);
      if (cloud.has_scanlines()) pack.Put(cloud.scanline[i]);
      if (!cloud.quality.empty()) pack.Put(cloud.quality[i]);
      if (!cloud.intensity.empty()) pack.Put(cloud.intensity[i]);
      for (const PointAttribute& attribute : cloud.attributes) {
        PutAttributeValue(attribute.type, attribute.Value(i), [&](auto v) { pack.Put(v); });
      }
    }
    out.write(buffer.data(), static_cast<std::streamsize>(buffer.size()));
  }
  if (!out) return absl::UnavailableError("cannot write PLY: output stream failed");
  return absl::OkStatus();
}

absl::Status WritePly(const std::filesystem::path& path, const PointCloud& cloud,
                      const WriteOptions& options) {
  return WriteFile(path, [&](std::ostream& out) { return WritePly(out, cloud, options); });
}

}  // namespace scanprep::io
