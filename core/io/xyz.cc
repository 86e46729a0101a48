// SPDX-License-Identifier: Apache-2.0
#include "core/io/xyz.h"

#include <cmath>
#include <optional>
#include <string_view>
#include <vector>

#include "absl/strings/str_cat.h"
#include "core/io/float_narrowing.h"
#include "core/io/read_file.h"
#include "core/io/text_fields.h"

namespace scanprep::io {
namespace {

std::string_view StripComment(std::string_view line) {
  const size_t hash = line.find('#');
  return hash == std::string_view::npos ? line : line.substr(0, hash);
}

// Starts a new scanline wherever consecutive points are more than `gap` apart.
void SplitProfiles(PointCloud& cloud, double gap) {
  const size_t n = cloud.size();
  cloud.scanline.resize(n);
  uint32_t line = 0;
  for (size_t i = 0; i < n; ++i) {
    if (i > 0 && (cloud.point(i) - cloud.point(i - 1)).cast<double>().norm() > gap) ++line;
    cloud.scanline[i] = line;
  }
}

absl::StatusOr<PointCloud> ParseXyz(std::string_view text, const std::string& name,
                                    double profile_gap) {
  if (!(profile_gap >= 0.0) || !std::isfinite(profile_gap)) {
    return absl::InvalidArgumentError(
        absl::StrCat("profile_gap must be a finite value >= 0, got ", profile_gap));
  }
  PointCloud cloud;
  // The shortest point line, "0 0 0\n", has 6 bytes.
  cloud.x.reserve(text.size() / 6);
  cloud.y.reserve(text.size() / 6);
  cloud.z.reserve(text.size() / 6);
  std::optional<uint64_t> declared_count;
  bool first_data_line = true;
  LineCursor cursor(text);
  std::vector<std::string_view> fields;
  std::string_view line;
  while (cursor.Next(line)) {
    SplitFields(StripComment(line), /*commas=*/true, fields);
    if (fields.empty()) continue;
    const bool is_first = first_data_line;
    first_data_line = false;
    uint64_t count = 0;
    if (is_first && fields.size() == 1 && ParseUint64(fields[0], count)) {
      declared_count = count;
      continue;
    }
    if (fields.size() < 3) {
      return absl::InvalidArgumentError(absl::StrCat(name, ": line ", cursor.line_number(),
                                                     ": expected x y z, found ", fields.size(),
                                                     " value(s)"));
    }
    float xyz[3];
    for (int k = 0; k < 3; ++k) {
      double value = 0.0;
      if (!ParseDouble(fields[k], value)) {
        return absl::InvalidArgumentError(
            absl::StrCat(name, ": line ", cursor.line_number(), ": column ", k + 1, " '",
                         std::string(fields[k]), "' is not a number"));
      }
      xyz[k] = NarrowToFloat(value);
      if (!std::isfinite(xyz[k])) {
        return absl::InvalidArgumentError(absl::StrCat(
            name, ": line ", cursor.line_number(), ": column ", k + 1, " is not a finite float"));
      }
    }
    cloud.x.push_back(xyz[0]);
    cloud.y.push_back(xyz[1]);
    cloud.z.push_back(xyz[2]);
  }
  if (declared_count && *declared_count != cloud.size()) {
    return absl::InvalidArgumentError(absl::StrCat(name, ": first line declares ", *declared_count,
                                                   " points but the file has ", cloud.size()));
  }
  if (profile_gap > 0.0) SplitProfiles(cloud, profile_gap);
  cloud.scans.push_back(ScanMeta{.id = std::filesystem::path(name).stem().string()});
  cloud.FinishLoading();
  return cloud;
}

}  // namespace

absl::StatusOr<PointCloud> ReadXyz(const std::filesystem::path& path, double profile_gap) {
  absl::StatusOr<std::string> text = ReadFileToString(path);
  if (!text.ok()) return text.status();
  return ParseXyz(*text, path.string(), profile_gap);
}

absl::StatusOr<PointCloud> ReadXyz(std::istream& in, const std::string& name_for_errors,
                                   double profile_gap) {
  absl::StatusOr<std::string> text = ReadStreamToString(in, name_for_errors);
  if (!text.ok()) return text.status();
  return ParseXyz(*text, name_for_errors, profile_gap);
}

}  // namespace scanprep::io
