// SPDX-License-Identifier: Apache-2.0
// PLY reader: the header fixes every element's size, one templated loop walks the elements for
// both encodings, and a builder validates vertex values as they arrive.
#include "core/io/ply.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <string_view>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "core/base/status_macros.h"
#include "core/io/byte_order.h"
#include "core/io/float_narrowing.h"
#include "core/io/local_frame.h"
#include "core/io/ply_header.h"
#include "core/io/read_file.h"
#include "core/io/text_fields.h"
#include "core/io/unmeasured_points.h"

namespace scanprep::io {
namespace {

using ply::Element;
using ply::Format;
using ply::Header;
using ply::Property;
using ply::ScalarType;

constexpr double kUint32Limit = 4294967296.0;

// True when `value` is an integer in [0, limit); stores it in `out`.
bool ToIndex(double value, double limit, uint64_t& out) {
  if (!(value >= 0.0 && value < limit && value == std::floor(value))) return false;
  out = static_cast<uint64_t>(value);
  return true;
}

class AsciiSource {
 public:
  AsciiSource(std::string_view body, size_t first_line, const std::string& name)
      : cursor_(body, first_line), name_(name) {}

  absl::Status BeginEntry(const Element& element, uint64_t index) {
    element_ = &element;
    index_ = index;
    next_ = 0;
    std::string_view line;
    do {
      if (!cursor_.Next(line)) {
        return absl::InvalidArgumentError(absl::StrCat(name_, ": data ends before ", element.name,
                                                       " ", index, " of ", element.count,
                                                       " (truncated file or wrong count)"));
      }
      SplitFields(line, /*commas=*/false, fields_);
    } while (fields_.empty());
    return absl::OkStatus();
  }

  absl::Status Read(ScalarType, const Property& property, double& out) {
    if (next_ >= fields_.size())
      return Error(absl::StrCat("too few values (no value for '", property.name, "')"));
    if (!ParseDouble(fields_[next_], out)) {
      return Error(absl::StrCat("'", property.name, "' value '", std::string(fields_[next_]),
                                "' is not a number"));
    }
    ++next_;
    return absl::OkStatus();
  }

  absl::Status CheckList(uint64_t items, const Property& property) const {
    if (items <= fields_.size() - next_) return absl::OkStatus();
    return Error(absl::StrCat("list '", property.name, "' declares ", items,
                              " items but the line has only ", fields_.size() - next_,
                              " more values"));
  }

  absl::Status EndEntry() const {
    if (next_ == fields_.size()) return absl::OkStatus();
    return Error(absl::StrCat(fields_.size() - next_, " more values than the header declares"));
  }

  absl::Status Finish() {
    std::string_view line;
    while (cursor_.Next(line)) {
      SplitFields(line, /*commas=*/false, fields_);
      if (!fields_.empty()) {
        return absl::InvalidArgumentError(
            absl::StrCat(name_, ": line ", cursor_.line_number(),
                         ": data after the last declared element (counts disagree)"));
      }
    }
    return absl::OkStatus();
  }

  absl::Status Error(std::string_view message) const {
    return absl::InvalidArgumentError(absl::StrCat(name_, ": line ", cursor_.line_number(), ": ",
                                                   element_->name, " ", index_, ": ",
                                                   std::string(message)));
  }

 private:
  LineCursor cursor_;
  const std::string& name_;
  std::vector<std::string_view> fields_;
  size_t next_ = 0;
  const Element* element_ = nullptr;
  uint64_t index_ = 0;
};

class BinarySource {
 public:
  BinarySource(std::string_view body, size_t body_offset, bool big_endian, const std::string& name)
      : body_(body),
        body_offset_(body_offset),
        swap_(big_endian != kHostIsBigEndian),
        name_(name) {}

  absl::Status BeginEntry(const Element& element, uint64_t index) {
    element_ = &element;
    index_ = index;
    return absl::OkStatus();
  }

  absl::Status Read(ScalarType type, const Property& property, double& out) {
    const size_t size = AttributeBytes(type);
    if (size > body_.size() - pos_) {
      return Error(absl::StrCat("data ends inside '", property.name, "' (truncated file)"));
    }
    out = Decode(type, body_.data() + pos_);
    pos_ += size;
    return absl::OkStatus();
  }

  absl::Status CheckList(uint64_t items, const Property& property) const {
    if (items <= (body_.size() - pos_) / AttributeBytes(property.type)) return absl::OkStatus();
    return Error(absl::StrCat("list '", property.name, "' declares ", items, " items but only ",
                              body_.size() - pos_, " bytes remain (truncated file)"));
  }

  absl::Status EndEntry() const { return absl::OkStatus(); }

  absl::Status Finish() const {
    if (pos_ == body_.size()) return absl::OkStatus();
    return absl::InvalidArgumentError(
        absl::StrCat(name_, ": byte ", body_offset_ + pos_, ": ", body_.size() - pos_,
                     " bytes after the last declared element (counts disagree)"));
  }

  absl::Status Error(std::string_view message) const {
    return absl::InvalidArgumentError(absl::StrCat(name_, ": byte ", body_offset_ + pos_, ": ",
                                                   element_->name, " ", index_, ": ",
                                                   std::string(message)));
  }

 private:
  template <class T>
  double Load(const char* p) const {
    T value;
    std::memcpy(&value, p, sizeof(T));
    return static_cast<double>(swap_ ? ByteSwapped(value) : value);
  }

  double Decode(ScalarType type, const char* p) const {
    switch (type) {
      case ScalarType::kInt8:
        return Load<int8_t>(p);
      case ScalarType::kUint8:
        return Load<uint8_t>(p);
      case ScalarType::kInt16:
        return Load<int16_t>(p);
      case ScalarType::kUint16:
        return Load<uint16_t>(p);
      case ScalarType::kInt32:
        return Load<int32_t>(p);
      case ScalarType::kUint32:
        return Load<uint32_t>(p);
      case ScalarType::kFloat32:
      case ScalarType::kFloat32Bits:  // no PLY type: the header parser never gives it
        return Load<float>(p);
      case ScalarType::kFloat64:
        return Load<double>(p);
    }
    return 0.0;
  }

  std::string_view body_;
  size_t body_offset_;
  bool swap_;
  const std::string& name_;
  size_t pos_ = 0;
  const Element* element_ = nullptr;
  uint64_t index_ = 0;
};

// Where a vertex property's values go.
enum class Slot : uint8_t {
  kSkip,
  kX,
  kY,
  kZ,
  kNx,
  kNy,
  kNz,
  kIntensity,
  kQuality,
  kScan,
  kScanline,
  kFlags,
  kAttribute  // any other scalar property: kept as a PointAttribute for the writers
};

Slot VertexSlot(std::string_view name) {
  if (name == "x") return Slot::kX;
  if (name == "y") return Slot::kY;
  if (name == "z") return Slot::kZ;
  if (name == "nx") return Slot::kNx;
  if (name == "ny") return Slot::kNy;
  if (name == "nz") return Slot::kNz;
  if (name == "intensity") return Slot::kIntensity;
  if (name == "confidence" || name == "quality") return Slot::kQuality;
  if (name == "scan" || name == "scan_index" || name == "scan_id") return Slot::kScan;
  if (name == "scanline" || name == "scanline_id" || name == "row") return Slot::kScanline;
  if (name == "flags") return Slot::kFlags;
  return Slot::kAttribute;
}

// Collects vertex values into a PointCloud, validating each one; the Store/GridEntry methods
// return nullptr when the value was accepted, otherwise the reason it was not.
class VertexBuilder {
 public:
  static absl::StatusOr<VertexBuilder> Create(const Header& header, const std::string& name) {
    VertexBuilder builder;
    const Element* vertex = nullptr;
    for (const Element& element : header.elements) {
      if (element.name == "vertex") vertex = &element;
      if (element.name == "range_grid") builder.grid_ = &element;
    }
    if (vertex == nullptr)
      return absl::InvalidArgumentError(absl::StrCat(name, ": no 'vertex' element"));
    builder.count_ = vertex->count;
    bool has[static_cast<size_t>(Slot::kAttribute) + 1] = {};
    for (const Property& property : vertex->properties) {
      const Slot slot = property.is_list ? Slot::kSkip : VertexSlot(property.name);
      builder.slots_.push_back(slot);
      has[static_cast<size_t>(slot)] = true;
      builder.attribute_of_.push_back(builder.cloud_.attributes.size());
      if (slot == Slot::kAttribute) {
        builder.cloud_.attributes.push_back({.name = property.name, .type = property.type});
      } else if (slot == Slot::kSkip) {
        builder.left_out_.push_back(property.name);
      }
    }
    for (const char* axis : {"x", "y", "z"}) {
      if (!has[static_cast<size_t>(VertexSlot(axis))]) {
        return absl::InvalidArgumentError(
            absl::StrCat(name, ": vertex element has no scalar property '", axis, "'"));
      }
    }
    // Double coordinates can hold a position far from zero to a precision float cannot: they
    // are kept until all are read and then stored relative to a local origin.
    for (size_t p = 0; p < vertex->properties.size(); ++p) {
      const Slot slot = builder.slots_[p];
      builder.wide_ |= (slot == Slot::kX || slot == Slot::kY || slot == Slot::kZ) &&
                       vertex->properties[p].type == ScalarType::kFloat64;
    }
    const bool has_normals = has[static_cast<size_t>(Slot::kNx)] ||
                             has[static_cast<size_t>(Slot::kNy)] ||
                             has[static_cast<size_t>(Slot::kNz)];
    if (has_normals &&
        !(has[static_cast<size_t>(Slot::kNx)] && has[static_cast<size_t>(Slot::kNy)] &&
          has[static_cast<size_t>(Slot::kNz)])) {
      return absl::InvalidArgumentError(
          absl::StrCat(name, ": vertex element has only some of nx, ny, nz"));
    }
    if (builder.grid_ != nullptr) {
      if (!header.num_cols) {
        return absl::InvalidArgumentError(
            absl::StrCat(name, ": range_grid element without 'obj_info num_cols'"));
      }
      const uint64_t cols = *header.num_cols;
      if (header.num_rows &&
          (builder.grid_->count % cols != 0 || builder.grid_->count / cols != *header.num_rows)) {
        return absl::InvalidArgumentError(
            absl::StrCat(name, ": range_grid has ", builder.grid_->count,
                         " entries but num_cols*num_rows = ", cols, "*", *header.num_rows));
      }
      builder.num_cols_ = *header.num_cols;
    }
    // The header parser has checked that the data section can hold `count_` vertices.
    PointCloud& c = builder.cloud_;
    const size_t n = builder.count_;
    c.x.resize(n);
    c.y.resize(n);
    c.z.resize(n);
    if (builder.wide_) builder.wide_coordinates_.Resize(n);
    if (has_normals) {
      c.nx.resize(n);
      c.ny.resize(n);
      c.nz.resize(n);
    }
    if (has[static_cast<size_t>(Slot::kIntensity)]) c.intensity.resize(n);
    if (has[static_cast<size_t>(Slot::kQuality)]) c.quality.resize(n);
    if (has[static_cast<size_t>(Slot::kScan)]) c.scan.resize(n);
    if (has[static_cast<size_t>(Slot::kScanline)] || builder.grid_ != nullptr) c.scanline.resize(n);
    if (has[static_cast<size_t>(Slot::kFlags)]) builder.flags_.resize(n);
    for (PointAttribute& attribute : c.attributes) attribute.Resize(n);
    return builder;
  }

  const char* Store(size_t property, uint64_t i, double value) {
    uint64_t index = 0;
    switch (slots_[property]) {
      case Slot::kSkip:
        return nullptr;
      case Slot::kAttribute: {
        // An ASCII file's text may say what its type cannot hold (300 for a uchar); a binary
        // one's bytes cannot.
        PointAttribute& attribute = cloud_.attributes[attribute_of_[property]];
        if (!HoldsValue(attribute.type, value)) return "not a value of the property's type";
        attribute.Set(i, value);
        return nullptr;
      }
      case Slot::kX:
        return StoreCoordinate(0, i, value);
      case Slot::kY:
        return StoreCoordinate(1, i, value);
      case Slot::kZ:
        return StoreCoordinate(2, i, value);
      case Slot::kNx:
        cloud_.nx[i] = NarrowToFloat(value);
        return nullptr;
      case Slot::kNy:
        cloud_.ny[i] = NarrowToFloat(value);
        return nullptr;
      case Slot::kNz:
        cloud_.nz[i] = NarrowToFloat(value);
        return nullptr;
      case Slot::kIntensity:
        cloud_.intensity[i] = NarrowToFloat(value);
        return nullptr;
      case Slot::kQuality:
        // NaN confidence means "unknown": treat it as untrustworthy.
        cloud_.quality[i] =
            std::isnan(value) ? 0.f : static_cast<float>(std::clamp(value, 0.0, 1.0));
        return nullptr;
      case Slot::kScan:
        // Bounding scan ids by the vertex count bounds the ScanMeta list built from them.
        if (!ToIndex(value, static_cast<double>(count_), index)) {
          return "scan index must be an integer below the vertex count";
        }
        cloud_.scan[i] = static_cast<uint32_t>(index);
        max_scan_ = std::max(max_scan_, index);
        return nullptr;
      case Slot::kScanline:
        if (!ToIndex(value, kUint32Limit, index))
          return "scanline must be a non-negative 32-bit integer";
        cloud_.scanline[i] = static_cast<uint32_t>(index);
        return nullptr;
      case Slot::kFlags:
        if (!ToIndex(value, 256.0, index)) return "flags must be an integer in [0,255]";
        flags_[i] = static_cast<uint8_t>(index);
        return nullptr;
    }
    return nullptr;
  }

  // `entry` is the range_grid entry index, `value` one of its vertex indices.
  const char* GridEntry(uint64_t entry, double value) {
    uint64_t vertex = 0;
    if (!ToIndex(value, static_cast<double>(count_), vertex))
      return "vertex index is not a valid vertex";
    if (grid_vertices_ > 0 && vertex <= last_grid_vertex_) {
      return "vertex indices must increase with the grid index (each vertex listed once)";
    }
    const uint64_t row = entry / num_cols_;
    if (row >= kUint32Limit) return "grid row does not fit 32 bits";
    cloud_.scanline[vertex] = static_cast<uint32_t>(row);
    last_grid_vertex_ = vertex;
    ++grid_vertices_;
    return nullptr;
  }

  bool is_grid(const Element& element) const { return &element == grid_; }

  absl::StatusOr<PointCloud> Finish(const std::string& name,
                                    std::vector<std::string>& warnings) && {
    if (grid_ != nullptr && grid_vertices_ != count_) {
      return absl::InvalidArgumentError(absl::StrCat(name, ": range_grid lists ", grid_vertices_,
                                                     " of the ", count_,
                                                     " vertices; every vertex needs a grid cell"));
    }
    if (wide_) SCANPREP_RETURN_IF_ERROR(wide_coordinates_.Narrow(cloud_, name));
    const std::string stem = std::filesystem::path(name).stem().string();
    if (max_scan_ == 0) {
      cloud_.scans.push_back(ScanMeta{.id = stem});
    } else {
      for (uint64_t k = 0; k <= max_scan_; ++k)
        cloud_.scans.push_back(ScanMeta{.id = absl::StrCat(stem, ":", k)});
    }
    cloud_.FinishLoading(std::move(flags_));
    if (!left_out_.empty()) {
      warnings.push_back(absl::StrCat(name, ": vertex list properties left out (",
                                      absl::StrJoin(left_out_, ", "),
                                      "): only one value per point is kept"));
    }
    UnmeasuredPoints unmeasured("vertex");
    DropUnmeasured(unmeasured);
    SCANPREP_RETURN_IF_ERROR(unmeasured.Finish(name, cloud_.size(), warnings));
    unmeasured.Record(cloud_.scans);
    return std::move(cloud_);
  }

 private:
  // NaN or infinity in the file is a scanner's "no measurement" (as in PCD and the API): such a
  // vertex is left out in Finish(). A finite value beyond float's range is an error.
  const char* StoreCoordinate(int axis, uint64_t i, double value) {
    if (wide_) {
      wide_coordinates_.at(axis, i) = value;  // checked by Narrow() against the origin
      return nullptr;
    }
    float& target = (axis == 0 ? cloud_.x : axis == 1 ? cloud_.y : cloud_.z)[i];
    target = NarrowToFloat(value);
    return std::isfinite(target) || !std::isfinite(value)
               ? nullptr
               : "coordinate beyond the range of a float";
  }

  // Leaves out the vertices without a position, every per-point array alike, counting them.
  void DropUnmeasured(UnmeasuredPoints& unmeasured) {
    const size_t n = cloud_.size();
    std::vector<uint32_t> kept;
    for (uint32_t i = 0; i < n; ++i) {
      if (std::isfinite(cloud_.x[i]) && std::isfinite(cloud_.y[i]) && std::isfinite(cloud_.z[i])) {
        kept.push_back(i);
      } else {
        unmeasured.Count(i, "", cloud_.scan[i]);
      }
    }
    if (kept.size() == n) return;
    auto compact = [&](auto& values) {
      if (values.empty()) return;
      for (size_t k = 0; k < kept.size(); ++k) values[k] = values[kept[k]];
      values.resize(kept.size());
    };
    compact(cloud_.x), compact(cloud_.y), compact(cloud_.z), compact(cloud_.scan);
    compact(cloud_.scanline), compact(cloud_.quality), compact(cloud_.intensity);
    compact(cloud_.nx), compact(cloud_.ny), compact(cloud_.nz), compact(cloud_.flags);
    for (PointAttribute& attribute : cloud_.attributes) {
      for (size_t k = 0; k < kept.size(); ++k) attribute.Set(k, attribute.Value(kept[k]));
      attribute.Resize(kept.size());
    }
  }

  PointCloud cloud_;
  std::vector<uint8_t> flags_;
  std::vector<Slot> slots_;
  std::vector<size_t> attribute_of_;   // per property: its index in cloud_.attributes
  std::vector<std::string> left_out_;  // vertex list properties, which no array can hold
  uint64_t count_ = 0;
  uint64_t max_scan_ = 0;
  const Element* grid_ = nullptr;
  uint64_t num_cols_ = 1;
  uint64_t grid_vertices_ = 0;
  uint64_t last_grid_vertex_ = 0;
  bool wide_ = false;  // a coordinate property is a double
  WideCoordinates wide_coordinates_;
};

template <class Source>
absl::Status Invalid(const Source& source, const Property& property, double value,
                     const char* why) {
  return source.Error(absl::StrCat("'", property.name, "' value ", value, ": ", why));
}

template <class Source>
absl::Status ReadElements(const Header& header, Source& source, VertexBuilder& vertices) {
  for (const Element& element : header.elements) {
    const bool is_vertex = element.name == "vertex";
    const bool is_grid = vertices.is_grid(element);
    for (uint64_t i = 0; i < element.count; ++i) {
      SCANPREP_RETURN_IF_ERROR(source.BeginEntry(element, i));
      for (size_t p = 0; p < element.properties.size(); ++p) {
        const Property& property = element.properties[p];
        double value = 0.0;
        if (!property.is_list) {
          SCANPREP_RETURN_IF_ERROR(source.Read(property.type, property, value));
          if (!is_vertex) continue;
          if (const char* why = vertices.Store(p, i, value))
            return Invalid(source, property, value, why);
          continue;
        }
        SCANPREP_RETURN_IF_ERROR(source.Read(property.count_type, property, value));
        uint64_t items = 0;
        if (!ToIndex(value, kUint32Limit, items)) {
          return Invalid(source, property, value, "list length is not a non-negative integer");
        }
        SCANPREP_RETURN_IF_ERROR(source.CheckList(items, property));
        const bool grid_indices = is_grid && property.name == "vertex_indices";
        for (uint64_t k = 0; k < items; ++k) {
          SCANPREP_RETURN_IF_ERROR(source.Read(property.type, property, value));
          if (!grid_indices) continue;
          if (const char* why = vertices.GridEntry(i, value))
            return Invalid(source, property, value, why);
        }
      }
      SCANPREP_RETURN_IF_ERROR(source.EndEntry());
    }
  }
  return source.Finish();
}

absl::StatusOr<PointCloud> ParsePly(std::string_view data, const std::string& name,
                                    std::vector<std::string>& warnings) {
  SCANPREP_ASSIGN_OR_RETURN(Header header, ply::ParseHeader(data, name));
  SCANPREP_ASSIGN_OR_RETURN(VertexBuilder vertices, VertexBuilder::Create(header, name));
  const std::string_view body = data.substr(header.body_offset);
  absl::Status status;
  if (header.format == Format::kAscii) {
    AsciiSource source(body, header.body_first_line, name);
    status = ReadElements(header, source, vertices);
  } else {
    BinarySource source(body, header.body_offset, header.format == Format::kBinaryBigEndian, name);
    status = ReadElements(header, source, vertices);
  }
  SCANPREP_RETURN_IF_ERROR(status);
  return std::move(vertices).Finish(name, warnings);
}

}  // namespace

absl::StatusOr<PointCloud> ReadPly(const std::filesystem::path& path,
                                   std::vector<std::string>& warnings) {
  SCANPREP_ASSIGN_OR_RETURN(std::string data, ReadFileToString(path));
  return ParsePly(data, path.string(), warnings);
}

absl::StatusOr<PointCloud> ReadPly(std::istream& in, const std::string& name_for_errors,
                                   std::vector<std::string>& warnings) {
  SCANPREP_ASSIGN_OR_RETURN(std::string data, ReadStreamToString(in, name_for_errors));
  return ParsePly(data, name_for_errors, warnings);
}

}  // namespace scanprep::io
