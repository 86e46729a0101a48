// SPDX-License-Identifier: Apache-2.0
#include "core/io/cloud_writer.h"

#include <algorithm>
#include <fstream>
#include <set>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "core/base/status_macros.h"

namespace scanprep::io {
namespace {

// `values`: a per-point array or an attribute (both have size()).
template <class Values>
absl::Status CheckSize(const Values& values, const char* field, size_t n, bool optional,
                       const char* format) {
  if (values.size() == n || (optional && values.size() == 0)) return absl::OkStatus();
  return absl::InvalidArgumentError(absl::StrCat("cannot write ", format, ": cloud.", field,
                                                 " has ", values.size(), " entries for ", n,
                                                 " points"));
}

}  // namespace

absl::Status CheckWritable(const PointCloud& cloud, const char* format) {
  const size_t n = cloud.size();
  const bool normals = cloud.has_normals();
  for (absl::Status s :
       {CheckSize(cloud.y, "y", n, false, format), CheckSize(cloud.z, "z", n, false, format),
        CheckSize(cloud.nx, "nx", n, true, format), CheckSize(cloud.ny, "ny", n, !normals, format),
        CheckSize(cloud.nz, "nz", n, !normals, format),
        CheckSize(cloud.flags, "flags", n, true, format),
        CheckSize(cloud.scan, "scan", n, true, format),
        CheckSize(cloud.scanline, "scanline", n, true, format),
        CheckSize(cloud.quality, "quality", n, true, format),
        CheckSize(cloud.intensity, "intensity", n, true, format)}) {
    SCANPREP_RETURN_IF_ERROR(s);
  }
  for (const PointAttribute& attribute : cloud.attributes) {
    SCANPREP_RETURN_IF_ERROR(CheckSize(attribute, attribute.name.c_str(), n, false, format));
  }
  return absl::OkStatus();
}

absl::Status CheckAttributeNames(const PointCloud& cloud, const char* format,
                                 std::initializer_list<std::string_view> written) {
  std::set<std::string_view> names(written);
  for (const PointAttribute& attribute : cloud.attributes) {
    const std::string& name = attribute.name;
    const bool word = !name.empty() && std::all_of(name.begin(), name.end(), [](char c) {
      return absl::ascii_isgraph(static_cast<unsigned char>(c));
    });
    if (!word || !names.insert(name).second) {
      return absl::InvalidArgumentError(absl::StrCat(
          "cannot write ", format, ": attribute '", name, "' ",
          word ? "has the name of another field" : "is not a word of printable characters"));
    }
  }
  return absl::OkStatus();
}

size_t WrittenCount(const PointCloud& cloud, const WriteOptions& options) {
  size_t count = 0;
  for (size_t i = 0; i < cloud.size(); ++i) count += Written(cloud, i, options);
  return count;
}

absl::Status WriteFile(const std::filesystem::path& path,
                       const std::function<absl::Status(std::ostream&)>& write) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) return absl::UnavailableError(absl::StrCat(path.string(), ": cannot open for writing"));
  if (absl::Status s = write(out); !s.ok()) {
    return absl::Status(s.code(), absl::StrCat(path.string(), ": ", s.message()));
  }
  out.close();
  if (!out) return absl::UnavailableError(absl::StrCat(path.string(), ": write failed"));
  return absl::OkStatus();
}

}  // namespace scanprep::io
