// SPDX-License-Identifier: Apache-2.0
#include "core/io/pcd_header.h"

#include <cmath>
#include <limits>
#include <set>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "core/base/status_macros.h"
#include "core/io/text_fields.h"

namespace scanprep::io::pcd {
namespace {

// Far above any real point type (PCL's largest, a 308-bin FPFH histogram, has COUNT 308), low
// enough that Σ SIZE·COUNT cannot overflow.
constexpr uint64_t kMaxCount = 1u << 16;

class HeaderParser {
 public:
  HeaderParser(std::string_view data, const std::string& name)
      : data_(data), cursor_(data), name_(name) {}

  absl::StatusOr<Header> Parse() {
    std::string_view line;
    std::vector<std::string_view> words;
    while (cursor_.Next(line)) {
      SplitFields(line, /*commas=*/false, words);
      if (words.empty() || words[0].front() == '#') continue;
      const std::string keyword = absl::AsciiStrToUpper(std::string(words[0]));
      const std::vector<std::string> values(words.begin() + 1, words.end());
      if (!seen_.insert(keyword == "COLUMNS" ? "FIELDS" : keyword).second) {
        return Error(absl::StrCat("keyword ", keyword, " appears twice"));
      }
      SCANPREP_RETURN_IF_ERROR(Keyword(keyword, values));
      if (keyword == "DATA") return Finish();
    }
    return absl::InvalidArgumentError(
        absl::StrCat(name_, ": the header has no DATA line (not a PCD file, or truncated)"));
  }

 private:
  absl::Status Keyword(const std::string& keyword, const std::vector<std::string>& values) {
    if (keyword == "VERSION") return Version(values);
    if (keyword == "FIELDS" || keyword == "COLUMNS") {
      if (values.empty()) return Error("FIELDS lists no field");
      for (const std::string& v : values) header_.fields.push_back(Field{.name = v});
      return absl::OkStatus();
    }
    if (keyword == "SIZE" || keyword == "TYPE" || keyword == "COUNT")
      return PerField(keyword, values);
    if (keyword == "WIDTH") return Count(keyword, values, header_.width);
    if (keyword == "HEIGHT") return Count(keyword, values, header_.height);
    if (keyword == "POINTS") {
      uint64_t points = 0;
      SCANPREP_RETURN_IF_ERROR(Count(keyword, values, points));
      declared_points_ = points;
      return absl::OkStatus();
    }
    if (keyword == "VIEWPOINT") return Viewpoint(values);
    if (keyword == "DATA") return DataKind(values);
    return Error(absl::StrCat("unknown header keyword '", keyword, "'"));
  }

  absl::Status Version(const std::vector<std::string>& values) {
    static constexpr const char* kKnown[] = {".7", "0.7", ".6", "0.6"};
    if (values.size() == 1) {
      for (const char* known : kKnown) {
        if (values[0] == known) return absl::OkStatus();
      }
    }
    return Error(
        absl::StrCat("VERSION '", absl::StrJoin(values, " "), "' is not supported (0.6 or 0.7)"));
  }

  absl::Status PerField(const std::string& keyword, const std::vector<std::string>& values) {
    if (header_.fields.empty()) return Error(absl::StrCat(keyword, " before FIELDS"));
    if (values.size() != header_.fields.size()) {
      return Error(absl::StrCat(keyword, " has ", values.size(), " entries but FIELDS names ",
                                header_.fields.size()));
    }
    for (size_t f = 0; f < values.size(); ++f) {
      Field& field = header_.fields[f];
      uint64_t number = 0;
      if (keyword == "TYPE") {
        if (values[f].size() != 1 ||
            std::string_view("IUF").find(values[f][0]) == std::string_view::npos) {
          return Error(
              absl::StrCat("TYPE of '", field.name, "' is '", values[f], "' (expected I, U or F)"));
        }
        field.type = values[f][0];
      } else if (!ParseUint64(values[f], number)) {
        return Error(
            absl::StrCat(keyword, " of '", field.name, "' is '", values[f], "', not an integer"));
      } else if (keyword == "SIZE") {
        if (number != 1 && number != 2 && number != 4 && number != 8) {
          return Error(
              absl::StrCat("SIZE of '", field.name, "' is ", number, " (expected 1, 2, 4 or 8)"));
        }
        field.size = static_cast<uint32_t>(number);
      } else {
        if (number == 0 || number > kMaxCount) {
          return Error(absl::StrCat("COUNT of '", field.name, "' is ", number, " (expected 1 to ",
                                    kMaxCount, ")"));
        }
        field.count = static_cast<uint32_t>(number);
      }
    }
    return absl::OkStatus();
  }

  absl::Status Count(const std::string& keyword, const std::vector<std::string>& values,
                     uint64_t& out) {
    if (values.size() != 1 || !ParseUint64(values[0], out)) {
      return Error(absl::StrCat(keyword, " '", absl::StrJoin(values, " "),
                                "' is not one non-negative integer"));
    }
    return absl::OkStatus();
  }

  absl::Status Viewpoint(const std::vector<std::string>& values) {
    std::array<double, 7> v{};
    if (values.size() != v.size()) {
      return Error(
          absl::StrCat("VIEWPOINT has ", values.size(), " values (expected tx ty tz qw qx qy qz)"));
    }
    for (size_t k = 0; k < v.size(); ++k) {
      if (!ParseDouble(values[k], v[k]) || !std::isfinite(v[k])) {
        return Error(
            absl::StrCat("VIEWPOINT value ", k + 1, " '", values[k], "' is not a finite number"));
      }
    }
    header_.viewpoint = v;
    return absl::OkStatus();
  }

  absl::Status DataKind(const std::vector<std::string>& values) {
    const std::string kind = values.size() == 1 ? absl::AsciiStrToLower(values[0]) : "";
    if (kind == "ascii") {
      header_.data = Data::kAscii;
    } else if (kind == "binary") {
      header_.data = Data::kBinary;
    } else if (kind == "binary_compressed") {
      header_.data = Data::kBinaryCompressed;
    } else {
      return Error(absl::StrCat("DATA '", absl::StrJoin(values, " "),
                                "' is not ascii, binary or binary_compressed"));
    }
    header_.body_offset = cursor_.offset();
    header_.body_first_line = cursor_.line_number() + 1;
    return absl::OkStatus();
  }

  absl::StatusOr<Header> Finish() {
    for (const char* required : {"FIELDS", "SIZE", "TYPE", "WIDTH"}) {
      if (!seen_.contains(required))
        return Error(absl::StrCat("the header has no ", required, " line"));
    }
    for (Field& field : header_.fields) {
      if (field.type == 'F' && field.size != 4 && field.size != 8) {
        return Error(absl::StrCat("field '", field.name, "' is TYPE F with SIZE ", field.size,
                                  " (expected 4 or 8)"));
      }
      field.offset = header_.point_bytes;
      field.value_index = header_.point_values;
      header_.point_bytes += static_cast<size_t>(field.size) * field.count;
      header_.point_values += field.count;
    }
    // WIDTH·HEIGHT is checked against POINTS before it is trusted: both are below 2^64.
    // An organised cloud's rows become 32-bit scanline indices.
    if (header_.height > std::numeric_limits<uint32_t>::max()) {
      return Error(absl::StrCat("HEIGHT ", header_.height, " exceeds the limit ",
                                std::numeric_limits<uint32_t>::max()));
    }
    const uint64_t grid = header_.width * header_.height;
    if (header_.height != 0 && grid / header_.height != header_.width) {
      return Error(
          absl::StrCat("WIDTH ", header_.width, " x HEIGHT ", header_.height, " overflows"));
    }
    header_.points = declared_points_.value_or(grid);
    if (header_.points != grid) {
      return Error(absl::StrCat("POINTS ", header_.points, " but WIDTH x HEIGHT = ", header_.width,
                                " x ", header_.height, " = ", grid));
    }
    return BoundByBody();
  }

  // Rejects counts the body cannot hold, before anyone allocates for them.
  absl::StatusOr<Header> BoundByBody() {
    const uint64_t body = data_.size() - header_.body_offset;
    if (header_.data == Data::kAscii) {
      // Every value takes at least one character and one separator (the last newline may be
      // missing).
      const uint64_t min_bytes = 2 * header_.point_values;
      if (header_.points > (body + 1) / min_bytes) {
        return Error(absl::StrCat("POINTS ", header_.points, " but the ascii body (", body,
                                  " bytes) cannot hold them (at least ", min_bytes,
                                  " bytes each)"));
      }
    } else if (header_.data == Data::kBinary) {
      const uint64_t record = header_.point_bytes;
      if (header_.points > body / record || header_.points * record != body) {
        return Error(absl::StrCat("POINTS ", header_.points, " of ", record, " bytes each need ",
                                  header_.points > body / record ? "more than" : "fewer than",
                                  " the ", body,
                                  " bytes of the binary body (truncated file or wrong count)"));
      }
    }
    return header_;
  }

  absl::Status Error(std::string_view message) const {
    return absl::InvalidArgumentError(
        absl::StrCat(name_, ": line ", cursor_.line_number(), ": ", std::string(message)));
  }

  std::string_view data_;
  LineCursor cursor_;
  const std::string& name_;
  Header header_;
  std::optional<uint64_t> declared_points_;
  std::set<std::string> seen_;
};

}  // namespace

absl::StatusOr<Header> ParseHeader(std::string_view data, const std::string& name) {
  return HeaderParser(data, name).Parse();
}

}  // namespace scanprep::io::pcd
