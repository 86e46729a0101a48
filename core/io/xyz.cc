// SPDX-License-Identifier: Apache-2.0
#include "core/io/xyz.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <string_view>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "core/base/status_macros.h"
#include "core/io/float_narrowing.h"
#include "core/io/local_frame.h"
#include "core/io/read_file.h"
#include "core/io/text_fields.h"
#include "core/io/unmeasured_points.h"

namespace scanprep::io {
namespace {

std::string_view StripComment(std::string_view line) {
  const size_t hash = line.find('#');
  return hash == std::string_view::npos ? line : line.substr(0, hash);
}

// Where each value is on a line: x y z first unless a "# columns:" line says otherwise; -1 =
// absent.
struct Columns {
  int x = 0, y = 1, z = 2, nx = -1, ny = -1, nz = -1, flags = -1, scanline = -1;
  size_t count = 3;    // values a point line needs
  bool named = false;  // by a "# columns:" line
  // The other named columns, kept as attributes for the output: (column, name).
  std::vector<std::pair<int, std::string>> others;
};

// The columns a "# columns: NAME..." comment names, or nothing for any other comment.
absl::StatusOr<std::optional<Columns>> ParseColumns(std::string_view line, const std::string& name,
                                                    size_t line_number) {
  // (std::string_view: Debian's abseil has its own string_view type.)
  auto consume = [&line](std::string_view prefix) {
    while (!line.empty() && (line.front() == ' ' || line.front() == '\t')) line.remove_prefix(1);
    if (!line.starts_with(prefix)) return false;
    line.remove_prefix(prefix.size());
    return true;
  };
  if (!consume("#") || !consume("columns:")) return std::nullopt;
  Columns c{.x = -1, .y = -1, .z = -1, .count = 0};
  std::vector<std::string_view> names;
  SplitFields(line, /*commas=*/true, names);
  for (size_t k = 0; k < names.size(); ++k) {
    bool known_name = false;
    for (auto [known, slot] : {std::pair{"x", &c.x},
                               {"y", &c.y},
                               {"z", &c.z},
                               {"nx", &c.nx},
                               {"ny", &c.ny},
                               {"nz", &c.nz},
                               {"flags", &c.flags},
                               {"scanline", &c.scanline}}) {
      if (names[k] == known) *slot = static_cast<int>(k), known_name = true;
    }
    if (!known_name) c.others.emplace_back(static_cast<int>(k), std::string(names[k]));
  }
  c.count = names.size();
  c.named = true;
  const int normals = (c.nx >= 0) + (c.ny >= 0) + (c.nz >= 0);
  if (c.x < 0 || c.y < 0 || c.z < 0 || (normals != 0 && normals != 3)) {
    return absl::InvalidArgumentError(
        absl::StrCat(name, ": line ", line_number,
                     ": '# columns:' must name x, y and z, and nx, ny, nz "
                     "all or none"));
  }
  return c;
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

// The values of one point line, read by column; a value that does not parse names the file, the
// line and the column.
class PointLine {
 public:
  PointLine(const std::vector<std::string_view>& fields, const std::string& name,
            size_t line_number)
      : fields_(fields), name_(name), line_number_(line_number) {}

  // Column k as a number.
  absl::Status Number(int k, double& value) const {
    if (ParseDouble(fields_[k], value)) return absl::OkStatus();
    return Error(
        absl::StrCat("column ", k + 1, " '", std::string(fields_[k]), "' is not a number"));
  }

  // Column k as a float appended to `to`.
  absl::Status Real(int k, std::vector<float>& to) const {
    double value = 0.0;
    SCANPREP_RETURN_IF_ERROR(Number(k, value));
    to.push_back(NarrowToFloat(value));
    return absl::OkStatus();
  }

  // Column k as an integer in [0, max].
  absl::Status Integer(int k, double max, double& value) const {
    SCANPREP_RETURN_IF_ERROR(Number(k, value));
    if (value >= 0 && value <= max && value == std::floor(value)) return absl::OkStatus();
    return Error(absl::StrCat("column ", k + 1, " '", std::string(fields_[k]),
                              "' is not an integer in [0, ", max, "]"));
  }

  size_t line_number() const { return line_number_; }

  absl::Status Error(const std::string& what) const {
    return absl::InvalidArgumentError(absl::StrCat(name_, ": line ", line_number_, ": ", what));
  }

 private:
  const std::vector<std::string_view>& fields_;
  const std::string& name_;
  const size_t line_number_;
};

// One point line into the cloud: its coordinates into `wide`, its normal, flags and scanline
// into `cloud`; a point whose coordinates are "nan" or "inf" as written is counted as unmeasured
// (a scanner's "no return") instead.
absl::Status ReadPoint(const PointLine& line, const Columns& columns, PointCloud& cloud,
                       WideCoordinates& wide, UnmeasuredPoints& unmeasured) {
  // Text carries any number of digits: coordinates are kept in double until all are read,
  // then stored relative to a local origin.
  const int xyz_columns[3] = {columns.x, columns.y, columns.z};
  double xyz[3];
  for (int k = 0; k < 3; ++k) SCANPREP_RETURN_IF_ERROR(line.Number(xyz_columns[k], xyz[k]));
  if (!std::isfinite(xyz[0]) || !std::isfinite(xyz[1]) || !std::isfinite(xyz[2])) {
    unmeasured.Count(line.line_number());
    return absl::OkStatus();
  }
  for (int k = 0; k < 3; ++k) {
    if (!std::isfinite(NarrowToFloat(xyz[k]))) {
      return line.Error(absl::StrCat("column ", xyz_columns[k] + 1, " is not a finite float"));
    }
  }
  wide.Push(xyz[0], xyz[1], xyz[2]);
  if (columns.nx >= 0) {
    SCANPREP_RETURN_IF_ERROR(line.Real(columns.nx, cloud.nx));
    SCANPREP_RETURN_IF_ERROR(line.Real(columns.ny, cloud.ny));
    SCANPREP_RETURN_IF_ERROR(line.Real(columns.nz, cloud.nz));
  }
  double value = 0;
  if (columns.flags >= 0) {
    SCANPREP_RETURN_IF_ERROR(line.Integer(columns.flags, 255, value));
    cloud.flags.push_back(static_cast<uint8_t>(value));
  }
  if (columns.scanline >= 0) {
    SCANPREP_RETURN_IF_ERROR(line.Integer(columns.scanline, 4294967295.0, value));
    cloud.scanline.push_back(static_cast<uint32_t>(value));
  }
  for (size_t a = 0; a < columns.others.size(); ++a) {
    SCANPREP_RETURN_IF_ERROR(line.Number(columns.others[a].first, value));
    cloud.attributes[a].Append(value);
  }
  return absl::OkStatus();
}

// Text has no types: each attribute gets the narrowest that holds all its values exactly, so a
// colour column of 0..255 is written back to PLY or PCD as uchar.
AttributeType TextAttributeType(const PointAttribute& values) {
  const auto all = [&](auto&& holds) {
    for (size_t i = 0; i < values.size(); ++i) {
      if (!holds(values.Value(i))) return false;
    }
    return true;
  };
  const auto within = [&](double lo, double hi) {
    return all([&](double v) { return v >= lo && v <= hi && v == std::floor(v); });
  };
  if (within(0, UINT8_MAX)) return AttributeType::kUint8;
  if (within(0, UINT16_MAX)) return AttributeType::kUint16;
  if (within(INT32_MIN, INT32_MAX)) return AttributeType::kInt32;
  const bool floats = all(
      [](double v) { return std::isnan(v) || static_cast<double>(static_cast<float>(v)) == v; });
  return floats ? AttributeType::kFloat32 : AttributeType::kFloat64;
}

absl::StatusOr<PointCloud> ParseXyz(std::string_view text, const std::string& name,
                                    std::vector<std::string>& warnings, double profile_gap) {
  if (!(profile_gap >= 0.0) || !std::isfinite(profile_gap)) {
    return absl::InvalidArgumentError(
        absl::StrCat("profile_gap must be a finite value >= 0, got ", profile_gap));
  }
  PointCloud cloud;
  std::optional<uint64_t> declared_count;
  bool first_data_line = true;
  LineCursor cursor(text);
  std::vector<std::string_view> fields;
  std::string_view line;
  Columns columns;
  size_t unnamed = 0;  // the most values of a line beyond the columns read
  WideCoordinates wide;
  UnmeasuredPoints unmeasured("line");
  while (cursor.Next(line)) {
    if (first_data_line) {
      SCANPREP_ASSIGN_OR_RETURN(auto named, ParseColumns(line, name, cursor.line_number()));
      if (named) {
        columns = *named;
        for (const auto& [column, attribute] : columns.others) {
          // Read as double, then stored in the narrowest type that holds every value.
          cloud.attributes.push_back({.name = attribute, .type = AttributeType::kFloat64});
        }
      }
    }
    SplitFields(StripComment(line), /*commas=*/true, fields);
    if (fields.empty()) continue;
    const bool is_first = first_data_line;
    first_data_line = false;
    uint64_t count = 0;
    if (is_first && fields.size() == 1 && ParseUint64(fields[0], count)) {
      declared_count = count;
      continue;
    }
    const PointLine point_line(fields, name, cursor.line_number());
    if (fields.size() < columns.count) {
      return point_line.Error(absl::StrCat("expected ",
                                           columns.named
                                               ? absl::StrCat(columns.count, " values (# columns:)")
                                               : std::string("x y z"),
                                           ", found ", fields.size(), " value(s)"));
    }
    SCANPREP_RETURN_IF_ERROR(ReadPoint(point_line, columns, cloud, wide, unmeasured));
    unnamed = std::max(unnamed, fields.size() - columns.count);
  }
  if (unnamed > 0) {
    warnings.push_back(absl::StrCat(
        name, ": ", unnamed, " column(s) after the ", columns.count,
        " read are left out: name every column in a '# columns: x y z ...' line before the first "
        "point to keep them for the output"));
  }
  for (PointAttribute& attribute : cloud.attributes) {
    attribute.ConvertTo(TextAttributeType(attribute));
  }
  SCANPREP_RETURN_IF_ERROR(wide.Narrow(cloud, name));
  const uint64_t rows = cloud.size() + unmeasured.count();
  if (declared_count && *declared_count != rows) {
    return absl::InvalidArgumentError(absl::StrCat(name, ": first line declares ", *declared_count,
                                                   " points but the file has ", rows));
  }
  SCANPREP_RETURN_IF_ERROR(unmeasured.Finish(name, cloud.size(), warnings));
  if (profile_gap > 0.0 && columns.scanline < 0) SplitProfiles(cloud, profile_gap);
  cloud.scans.push_back(ScanMeta{.id = std::filesystem::path(name).stem().string()});
  unmeasured.Record(cloud.scans);
  cloud.FinishLoading(std::exchange(cloud.flags, {}));
  return cloud;
}

}  // namespace

absl::StatusOr<PointCloud> ReadXyz(const std::filesystem::path& path,
                                   std::vector<std::string>& warnings, double profile_gap) {
  SCANPREP_ASSIGN_OR_RETURN(std::string text, ReadFileToString(path));
  return ParseXyz(text, path.string(), warnings, profile_gap);
}

absl::StatusOr<PointCloud> ReadXyz(std::istream& in, const std::string& name_for_errors,
                                   std::vector<std::string>& warnings, double profile_gap) {
  SCANPREP_ASSIGN_OR_RETURN(std::string text, ReadStreamToString(in, name_for_errors));
  return ParseXyz(text, name_for_errors, warnings, profile_gap);
}

}  // namespace scanprep::io
