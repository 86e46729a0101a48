// SPDX-License-Identifier: Apache-2.0
#include "core/io/conf.h"

#include <cmath>
#include <string_view>

#include "absl/strings/str_cat.h"
#include "core/base/status_macros.h"
#include "core/io/read_file.h"
#include "core/io/text_fields.h"

namespace scanprep::io {
namespace {

absl::StatusOr<std::vector<ConfEntry>> ParseConf(std::string_view text, const std::string& name) {
  std::vector<ConfEntry> entries;
  LineCursor cursor(text);
  std::vector<std::string_view> fields;
  std::string_view line;
  auto error = [&](std::string_view message) {
    return absl::InvalidArgumentError(
        absl::StrCat(name, ": line ", cursor.line_number(), ": ", std::string(message)));
  };
  while (cursor.Next(line)) {
    SplitFields(line, /*commas=*/false, fields);
    if (fields.empty() || fields[0].front() == '#' || fields[0] == "camera") continue;
    if (fields[0] != "bmesh" && fields[0] != "mesh") {
      return error(absl::StrCat("unknown keyword '", std::string(fields[0]),
                                "' (expected bmesh or camera)"));
    }
    if (fields.size() != 9) {
      return error(absl::StrCat("expected '", std::string(fields[0]),
                                " <file> tx ty tz qx qy qz qw', found ", fields.size(), " fields"));
    }
    double v[7];
    for (int k = 0; k < 7; ++k) {
      if (!ParseDouble(fields[2 + k], v[k]) || !std::isfinite(v[k])) {
        return error(absl::StrCat("field ", 3 + k, " '", std::string(fields[2 + k]),
                                  "' is not a finite number"));
      }
    }
    Eigen::Quaterniond q(v[6], v[3], v[4], v[5]);  // Eigen takes (w, x, y, z)
    // stableNorm: the plain norm squares the components and overflows to inf above ~1e154,
    // which would "normalise" a valid direction to the zero quaternion.
    const double norm = q.coeffs().stableNorm();
    if (!(norm > 1e-6)) return error("quaternion has (near) zero length");
    q.coeffs() /= norm;
    entries.push_back(
        ConfEntry{.file = std::string(fields[1]),
                  .pose = RigidPose{.rotation = q.conjugate(), .translation = {v[0], v[1], v[2]}}});
  }
  return entries;
}

}  // namespace

absl::StatusOr<std::vector<ConfEntry>> ReadConf(const std::filesystem::path& path) {
  SCANPREP_ASSIGN_OR_RETURN(std::string text, ReadFileToString(path));
  return ParseConf(text, path.string());
}

absl::StatusOr<std::vector<ConfEntry>> ReadConf(std::istream& in,
                                                const std::string& name_for_errors) {
  SCANPREP_ASSIGN_OR_RETURN(std::string text, ReadStreamToString(in, name_for_errors));
  return ParseConf(text, name_for_errors);
}

}  // namespace scanprep::io
