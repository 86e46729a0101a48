// SPDX-License-Identifier: Apache-2.0
// PCD 0.7 writer, DATA binary: what PCL's pcl::io::loadPCDFile and scanprep's ReadPcd read back.
#include <cstring>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "core/base/status_macros.h"
#include "core/io/byte_order.h"
#include "core/io/cloud_writer.h"
#include "core/io/pcd.h"

namespace scanprep::io {
namespace {

// One PCD field: its name, SIZE and TYPE.
struct OutField {
  const char* name;
  int size;
  char type;
};

template <class T>
void Append(std::string& record, T value) {
  if constexpr (kHostIsBigEndian) value = ByteSwapped(value);
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  record.append(bytes, sizeof(T));
}

}  // namespace

absl::Status WritePcd(std::ostream& out, const PointCloud& cloud, const WriteOptions& options) {
  SCANPREP_RETURN_IF_ERROR(CheckWritable(cloud, "PCD"));
  SCANPREP_RETURN_IF_ERROR(CheckAttributeNames(
      cloud, "PCD",
      {"x", "y", "z", "normal_x", "normal_y", "normal_z", "intensity", "flags", "scanline"}));
  const bool normals = cloud.has_normals(), scanlines = cloud.has_scanlines();
  const bool intensity = !cloud.intensity.empty();
  const bool wide = WritesDoubleCoordinates(cloud);
  const int coordinate = wide ? 8 : 4;
  std::vector<OutField> fields = {
      {"x", coordinate, 'F'}, {"y", coordinate, 'F'}, {"z", coordinate, 'F'}};
  if (normals)
    fields.insert(fields.end(), {{"normal_x", 4, 'F'}, {"normal_y", 4, 'F'}, {"normal_z", 4, 'F'}});
  if (intensity) fields.push_back({"intensity", 4, 'F'});
  fields.push_back({"flags", 1, 'U'});
  if (scanlines) fields.push_back({"scanline", 4, 'U'});
  for (const PointAttribute& a : cloud.attributes) {
    const char type = !IsIntegerAttribute(a.type) ? 'F' : IsSignedAttribute(a.type) ? 'I' : 'U';
    fields.push_back({a.name.c_str(), AttributeBytes(a.type), type});
  }
  auto column = [&](auto get) {
    std::vector<std::string> v;
    for (const OutField& f : fields) v.push_back(get(f));
    return absl::StrJoin(v, " ");
  };
  const size_t count = WrittenCount(cloud, options);
  const std::string header = absl::StrCat(
      "# .PCD v0.7 - Point Cloud Data file format (written by scanprep)\nVERSION 0.7\nFIELDS ",
      column([](const OutField& f) { return std::string(f.name); }), "\nSIZE ",
      column([](const OutField& f) { return absl::StrCat(f.size); }), "\nTYPE ",
      column([](const OutField& f) { return std::string(1, f.type); }), "\nCOUNT ",
      column([](const OutField&) { return std::string("1"); }), "\nWIDTH ", count,
      "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS ", count, "\nDATA binary\n");
  out.write(header.data(), static_cast<std::streamsize>(header.size()));
  std::string record;
  for (size_t i = 0; i < cloud.size() && out; ++i) {
    if (!Written(cloud, i, options)) continue;
    record.clear();
    if (wide) {
      const Eigen::Vector3d p = WorldPoint(cloud, i);
      Append(record, p.x()), Append(record, p.y()), Append(record, p.z());
    } else {
      Append(record, cloud.x[i]), Append(record, cloud.y[i]), Append(record, cloud.z[i]);
    }
    if (normals) {
      Append(record, cloud.nx[i]);
      Append(record, cloud.ny[i]);
      Append(record, cloud.nz[i]);
    }
    if (intensity) Append(record, cloud.intensity[i]);
    Append(record, cloud.flags.empty() ? uint8_t{0} : cloud.flags[i]);
    if (scanlines) Append(record, cloud.scanline[i]);
    for (const PointAttribute& a : cloud.attributes) {
      PutAttributeValue(a.type, a.Value(i), [&](auto v) { Append(record, v); });
    }
    out.write(record.data(), static_cast<std::streamsize>(record.size()));
  }
  if (!out) return absl::UnavailableError("cannot write PCD: output stream failed");
  return absl::OkStatus();
}

absl::Status WritePcd(const std::filesystem::path& path, const PointCloud& cloud,
                      const WriteOptions& options) {
  return WriteFile(path, [&](std::ostream& out) { return WritePcd(out, cloud, options); });
}

}  // namespace scanprep::io
