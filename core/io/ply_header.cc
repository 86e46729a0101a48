// SPDX-License-Identifier: Apache-2.0
#include "core/io/ply_header.h"

#include <array>
#include <utility>

#include "absl/strings/str_cat.h"
#include "core/base/status_macros.h"
#include "core/io/text_fields.h"

namespace scanprep::io::ply {
namespace {

constexpr std::array<std::pair<std::string_view, ScalarType>, 16> kTypeNames = {{
    {"char", ScalarType::kInt8},
    {"int8", ScalarType::kInt8},
    {"uchar", ScalarType::kUint8},
    {"uint8", ScalarType::kUint8},
    {"short", ScalarType::kInt16},
    {"int16", ScalarType::kInt16},
    {"ushort", ScalarType::kUint16},
    {"uint16", ScalarType::kUint16},
    {"int", ScalarType::kInt32},
    {"int32", ScalarType::kInt32},
    {"uint", ScalarType::kUint32},
    {"uint32", ScalarType::kUint32},
    {"float", ScalarType::kFloat32},
    {"float32", ScalarType::kFloat32},
    {"double", ScalarType::kFloat64},
    {"float64", ScalarType::kFloat64},
}};

std::optional<ScalarType> LookupType(std::string_view name) {
  for (const auto& [type_name, type] : kTypeNames) {
    if (type_name == name) return type;
  }
  return std::nullopt;
}

// The fewest bytes one entry of `element` can occupy: in ASCII every value takes at least one
// character plus a separator, in binary every scalar its size and every list its count.
uint64_t MinEntryBytes(const Element& element, Format format) {
  uint64_t bytes = 0;
  for (const Property& p : element.properties) {
    if (format == Format::kAscii) {
      bytes += 2;
    } else {
      bytes += AttributeBytes(p.is_list ? p.count_type : p.type);
    }
  }
  return bytes;
}

class HeaderParser {
 public:
  HeaderParser(std::string_view data, const std::string& name)
      : cursor_(data), data_(data), name_(name) {}

  absl::StatusOr<Header> Parse() {
    std::string_view line;
    if (!cursor_.Next(line) || line != "ply") {
      return absl::InvalidArgumentError(
          absl::StrCat(name_, ": not a PLY file (first line is not \"ply\")"));
    }
    bool have_format = false;
    while (cursor_.Next(line)) {
      SplitFields(line, /*commas=*/false, fields_);
      if (fields_.empty()) continue;
      const std::string_view keyword = fields_[0];
      absl::Status status;
      if (keyword == "end_header") {
        if (!have_format) return Error("no 'format' line before end_header");
        header_.body_offset = cursor_.offset();
        header_.body_first_line = cursor_.line_number() + 1;
        return Finish();
      } else if (keyword == "format") {
        status = ParseFormat();
        have_format = true;
      } else if (keyword == "element") {
        status = ParseElement();
      } else if (keyword == "property") {
        status = ParseProperty();
      } else if (keyword == "obj_info") {
        status = ParseObjInfo();
      } else if (keyword != "comment") {
        status = Error(absl::StrCat("unknown header keyword '", std::string(keyword), "'"));
      }
      SCANPREP_RETURN_IF_ERROR(status);
    }
    return absl::InvalidArgumentError(absl::StrCat(name_, ": header has no end_header line"));
  }

 private:
  absl::Status Error(std::string_view message) const {
    return absl::InvalidArgumentError(
        absl::StrCat(name_, ": line ", cursor_.line_number(), ": ", std::string(message)));
  }

  absl::Status ParseFormat() {
    if (fields_.size() != 3) return Error("expected 'format <type> <version>'");
    if (fields_[1] == "ascii") {
      header_.format = Format::kAscii;
    } else if (fields_[1] == "binary_little_endian") {
      header_.format = Format::kBinaryLittleEndian;
    } else if (fields_[1] == "binary_big_endian") {
      header_.format = Format::kBinaryBigEndian;
    } else {
      return Error(absl::StrCat("unsupported format '", std::string(fields_[1]), "'"));
    }
    if (fields_[2] != "1.0")
      return Error(absl::StrCat("unsupported PLY version '", std::string(fields_[2]), "'"));
    return absl::OkStatus();
  }

  absl::Status ParseElement() {
    if (fields_.size() != 3) return Error("expected 'element <name> <count>'");
    Element element{.name = std::string(fields_[1])};
    if (!ParseUint64(fields_[2], element.count)) {
      return Error(absl::StrCat("element count '", std::string(fields_[2]),
                                "' is not a non-negative integer"));
    }
    for (const Element& other : header_.elements) {
      if (other.name == element.name)
        return Error(absl::StrCat("duplicate element '", element.name, "'"));
    }
    header_.elements.push_back(std::move(element));
    return absl::OkStatus();
  }

  absl::Status ParseProperty() {
    if (header_.elements.empty()) return Error("property before any element");
    Property property;
    if (fields_.size() == 3) {
      const auto type = LookupType(fields_[1]);
      if (!type)
        return Error(absl::StrCat("unknown property type '", std::string(fields_[1]), "'"));
      property.type = *type;
      property.name = std::string(fields_[2]);
    } else if (fields_.size() == 5 && fields_[1] == "list") {
      const auto count_type = LookupType(fields_[2]);
      const auto item_type = LookupType(fields_[3]);
      if (!count_type || !item_type) return Error("unknown type in list property");
      if (!IsIntegerAttribute(*count_type)) return Error("list count type must be an integer type");
      property.is_list = true;
      property.count_type = *count_type;
      property.type = *item_type;
      property.name = std::string(fields_[4]);
    } else {
      return Error(
          "expected 'property <type> <name>' or 'property list <count type> <item type> <name>'");
    }
    Element& element = header_.elements.back();
    for (const Property& other : element.properties) {
      if (other.name == property.name) {
        return Error(absl::StrCat("duplicate property '", property.name, "' in element '",
                                  element.name, "'"));
      }
    }
    element.properties.push_back(std::move(property));
    return absl::OkStatus();
  }

  absl::Status ParseObjInfo() {
    if (fields_.size() != 3 || (fields_[1] != "num_cols" && fields_[1] != "num_rows"))
      return absl::OkStatus();
    uint64_t value = 0;
    if (!ParseUint64(fields_[2], value) || value == 0) {
      return Error(
          absl::StrCat("obj_info ", std::string(fields_[1]), " must be a positive integer"));
    }
    (fields_[1] == "num_cols" ? header_.num_cols : header_.num_rows) = value;
    return absl::OkStatus();
  }

  // Rejects counts the data section cannot hold, before anyone allocates for them.
  absl::StatusOr<Header> Finish() {
    const uint64_t body_bytes = data_.size() - header_.body_offset;
    // The last ASCII value may lack its trailing newline.
    uint64_t budget = body_bytes + (header_.format == Format::kAscii ? 1 : 0);
    for (const Element& element : header_.elements) {
      if (element.count == 0) continue;
      if (element.properties.empty()) {
        return absl::InvalidArgumentError(
            absl::StrCat(name_, ": element '", element.name, "' has entries but no properties"));
      }
      const uint64_t min_bytes = MinEntryBytes(element, header_.format);
      if (element.count > budget / min_bytes) {
        return absl::InvalidArgumentError(
            absl::StrCat(name_, ": element '", element.name, "' declares ", element.count,
                         " entries but the data section (", body_bytes,
                         " bytes) cannot hold them (at least ", min_bytes, " bytes each)"));
      }
      budget -= element.count * min_bytes;
    }
    return std::move(header_);
  }

  LineCursor cursor_;
  std::string_view data_;
  const std::string& name_;
  std::vector<std::string_view> fields_;
  Header header_;
};

}  // namespace

std::string TypeName(ScalarType type) {
  if (type == ScalarType::kFloat32Bits) type = ScalarType::kFloat32;  // a float with its bits
  for (const auto& [type_name, t] : kTypeNames) {
    if (t == type) return std::string(type_name);  // the first, classic name
  }
  return "double";
}

absl::StatusOr<Header> ParseHeader(std::string_view data, const std::string& name) {
  return HeaderParser(data, name).Parse();
}

}  // namespace scanprep::io::ply
