// SPDX-License-Identifier: Apache-2.0
// PCD reader: the header fixes the layout, one templated loop reads the points from any of the
// three bodies, and a builder keeps the valid ones.
#include "core/io/pcd.h"

#include <lzf.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <optional>
#include <string_view>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "core/base/status_macros.h"
#include "core/io/byte_order.h"
#include "core/io/float_narrowing.h"
#include "core/io/local_frame.h"
#include "core/io/pcd_header.h"
#include "core/io/read_file.h"
#include "core/io/text_fields.h"
#include "core/io/unmeasured_points.h"

namespace scanprep::io {
namespace {

using pcd::Data;
using pcd::Field;
using pcd::Header;

// A back-reference in an LZF stream emits at most 264 bytes from 3 input bytes, so no stream
// decompresses to more than 88 times its size; larger claims are rejected before allocating.
constexpr uint64_t kMaxLzfRatio = 88;

// The point values the reader keeps, in this order.
enum Slot : uint8_t { kX, kY, kZ, kNx, kNy, kNz, kIntensity, kFlags, kScanline, kSlots };
constexpr const char* kSlotNames[kSlots] = {
    "x", "y", "z", "normal_x", "normal_y", "normal_z", "intensity", "flags", "scanline"};

// The integer fields scanprep writes (WritePcd): read only as it writes them, so another
// program's field of the same name and another meaning is left alone (and named in a warning).
bool Readable(int slot, const Field& field) {
  if (slot == kFlags) return field.type == 'U' && field.size == 1;
  if (slot == kScanline) return field.type == 'U' && field.size == 4;
  return true;
}

// Decodes one little-endian binary value of `field`.
double DecodeBinary(const Field& field, const char* p) {
  auto load = [p]<class T>(T) {
    T value;
    std::memcpy(&value, p, sizeof(T));
    return static_cast<double>(kHostIsBigEndian ? ByteSwapped(value) : value);
  };
  switch (field.type) {
    case 'F':
      return field.size == 4 ? load(float{}) : load(double{});
    case 'I':
      switch (field.size) {
        case 1:
          return load(int8_t{});
        case 2:
          return load(int16_t{});
        case 4:
          return load(int32_t{});
        default:
          return load(int64_t{});
      }
    default:
      switch (field.size) {
        case 1:
          return load(uint8_t{});
        case 2:
          return load(uint16_t{});
        case 4:
          return load(uint32_t{});
        default:
          return load(uint64_t{});
      }
  }
}

// The attribute type of a PCD TYPE and SIZE: none for 8-byte integers, which a double does not
// hold exactly.
std::optional<AttributeType> StorageTypeOf(char type, uint32_t size) {
  switch (type) {
    case 'F':
      return size == 4   ? std::optional(AttributeType::kFloat32)
             : size == 8 ? std::optional(AttributeType::kFloat64)
                         : std::nullopt;
    case 'I':
      return size == 1   ? std::optional(AttributeType::kInt8)
             : size == 2 ? std::optional(AttributeType::kInt16)
             : size == 4 ? std::optional(AttributeType::kInt32)
                         : std::nullopt;
    default:
      return size == 1   ? std::optional(AttributeType::kUint8)
             : size == 2 ? std::optional(AttributeType::kUint16)
             : size == 4 ? std::optional(AttributeType::kUint32)
                         : std::nullopt;
  }
}

// Binary records, point after point; or, for binary_compressed, every field's values for all
// points before the next field's (`soa`).
class BinarySource {
 public:
  BinarySource(std::string_view bytes, const Header& header, bool soa)
      : bytes_(bytes), header_(header) {
    size_t start = 0;
    for (const Field& field : header.fields) {
      if (soa && field.name == "_") {
        field_start_.push_back(start);  // PCL leaves padding out of compressed data
        continue;
      }
      field_start_.push_back(soa ? start : field.offset);
      start += soa ? static_cast<size_t>(field.size) * field.count * header.points : 0;
    }
    stride_ = soa ? 0 : header.point_bytes;
  }

  absl::Status BeginPoint(uint64_t i) {
    point_ = i;
    return absl::OkStatus();
  }

  absl::Status Get(size_t f, double& out) const {
    out = DecodeBinary(header_.fields[f], Value(f));
    return absl::OkStatus();
  }

  // A 4-byte field's bits (a packed colour), not its value.
  absl::Status GetBits(size_t f, uint32_t& out) const {
    std::memcpy(&out, Value(f), 4);
    if (kHostIsBigEndian) out = ByteSwapped(out);
    return absl::OkStatus();
  }

 private:
  // Field f's bytes for the current point.
  const char* Value(size_t f) const {
    const Field& field = header_.fields[f];
    const size_t at = stride_ != 0 ? point_ * stride_ + field_start_[f]
                                   : field_start_[f] + point_ * field.count * field.size;
    return bytes_.data() + at;
  }

  std::string_view bytes_;
  const Header& header_;
  std::vector<size_t> field_start_;
  size_t stride_ = 0;
  uint64_t point_ = 0;
};

class AsciiSource {
 public:
  AsciiSource(std::string_view body, const Header& header, const std::string& name)
      : cursor_(body, header.body_first_line), header_(header), name_(name) {}

  absl::Status BeginPoint(uint64_t i) {
    std::string_view line;
    do {
      if (!cursor_.Next(line)) {
        return absl::InvalidArgumentError(absl::StrCat(name_, ": data ends before point ", i,
                                                       " of POINTS ", header_.points,
                                                       " (truncated file or wrong count)"));
      }
      SplitFields(line, /*commas=*/false, values_);
    } while (values_.empty());
    if (values_.size() != header_.point_values) {
      return Error(absl::StrCat("point ", i, " has ", values_.size(),
                                " values but the fields declare ", header_.point_values));
    }
    return absl::OkStatus();
  }

  absl::Status Get(size_t f, double& out) const {
    const Field& field = header_.fields[f];
    const std::string_view token = values_[field.value_index];
    if (!ParseDouble(token, out)) {
      return Error(absl::StrCat("field '", field.name, "' value '", std::string(token),
                                "' is not a number"));
    }
    // 8-byte integers have no attribute type; no slot or attribute takes them.
    const std::optional<AttributeType> type = StorageTypeOf(field.type, field.size);
    if (!type || HoldsValue(*type, out)) return absl::OkStatus();
    return Error(absl::StrCat("field '", field.name, "' value '", std::string(token),
                              "' is not a value of its TYPE ", std::string(1, field.type), " SIZE ",
                              field.size));
  }

  // A packed colour: PCL writes a float "rgb" in ASCII as the integer of its bits; a float's
  // text is taken as its value's bits.
  absl::Status GetBits(size_t f, uint32_t& out) const {
    const std::string_view token = values_[header_.fields[f].value_index];
    uint64_t bits = 0;
    if (ParseUint64(token, bits) && bits <= UINT32_MAX) {
      out = static_cast<uint32_t>(bits);
      return absl::OkStatus();
    }
    double value = 0;
    SCANPREP_RETURN_IF_ERROR(Get(f, value));
    out = std::bit_cast<uint32_t>(static_cast<float>(value));
    return absl::OkStatus();
  }

  absl::Status Finish() {
    std::string_view line;
    while (cursor_.Next(line)) {
      SplitFields(line, /*commas=*/false, values_);
      if (!values_.empty())
        return Error(absl::StrCat("data after the last of POINTS ", header_.points));
    }
    return absl::OkStatus();
  }

 private:
  absl::Status Error(std::string_view message) const {
    return absl::InvalidArgumentError(
        absl::StrCat(name_, ": line ", cursor_.line_number(), ": ", std::string(message)));
  }

  LineCursor cursor_;
  const Header& header_;
  const std::string& name_;
  std::vector<std::string_view> values_;
};

// The attribute type of a field of one value that a double holds exactly.
std::optional<AttributeType> AttributeTypeOf(const Field& field) {
  if (field.count != 1) return std::nullopt;
  if (field.type == 'F' && field.size == 4 && (field.name == "rgb" || field.name == "rgba")) {
    return AttributeType::kFloat32Bits;  // PCL's packed colour
  }
  return StorageTypeOf(field.type, field.size);
}

// Which field feeds each slot and each attribute (the other fields of one value: rgb, label,
// curvature…); the fields nobody can hold are listed for the warning.
struct Layout {
  std::array<std::optional<size_t>, kSlots> field;
  std::vector<size_t> attribute_fields;
  std::vector<std::string> unused;
};

absl::StatusOr<Layout> MapFields(const Header& header, const std::string& name) {
  Layout layout;
  for (size_t f = 0; f < header.fields.size(); ++f) {
    const Field& field = header.fields[f];
    if (field.name == "_") continue;
    int slot = 0;
    while (slot < kSlots && field.name != kSlotNames[slot]) ++slot;
    if (slot == kSlots || !Readable(slot, field)) {
      if (slot == kSlots && AttributeTypeOf(field)) {  // not a slot's name in another type
        layout.attribute_fields.push_back(f);
      } else {
        layout.unused.push_back(absl::StrCat(field.name, " (", std::string(1, field.type),
                                             field.size, " x ", field.count, ")"));
      }
      continue;
    }
    if (layout.field[slot]) {
      return absl::InvalidArgumentError(
          absl::StrCat(name, ": field '", field.name, "' appears twice"));
    }
    if (field.count != 1) {
      return absl::InvalidArgumentError(absl::StrCat(name, ": field '", field.name, "' has COUNT ",
                                                     field.count, " (expected 1)"));
    }
    layout.field[slot] = f;
  }
  for (int slot : {kX, kY, kZ}) {
    if (!layout.field[slot]) {
      return absl::InvalidArgumentError(absl::StrCat(name, ": no field '", kSlotNames[slot], "'"));
    }
  }
  const int normals =
      layout.field[kNx].has_value() + layout.field[kNy].has_value() + layout.field[kNz].has_value();
  if (normals != 0 && normals != 3) {
    return absl::InvalidArgumentError(
        absl::StrCat(name, ": only some of normal_x, normal_y, normal_z"));
  }
  return layout;
}

void Reserve(const Header& header, const Layout& layout, PointCloud& cloud) {
  const size_t n = header.points;
  for (std::vector<float>* v : {&cloud.x, &cloud.y, &cloud.z}) v->reserve(n);
  if (layout.field[kNx]) {
    for (std::vector<float>* v : {&cloud.nx, &cloud.ny, &cloud.nz}) v->reserve(n);
  }
  if (layout.field[kIntensity]) cloud.intensity.reserve(n);
  if (layout.field[kFlags]) cloud.flags.reserve(n);
  if (header.height > 1 || layout.field[kScanline]) cloud.scanline.reserve(n);
}

// Reads every point from `source`, keeping those with finite coordinates.
template <class Source>
absl::Status ReadPoints(const Header& header, const Layout& layout, Source& source,
                        PointCloud& cloud, WideCoordinates* wide, UnmeasuredPoints& invalid) {
  const bool normals = layout.field[kNx].has_value();
  const bool intensity = layout.field[kIntensity].has_value();
  const bool flags = layout.field[kFlags].has_value();
  const bool scanline = layout.field[kScanline].has_value();
  const bool organised = header.height > 1;
  for (uint64_t i = 0; i < header.points; ++i) {
    SCANPREP_RETURN_IF_ERROR(source.BeginPoint(i));
    std::array<double, kSlots> raw{};
    for (int slot = 0; slot < kSlots; ++slot) {
      if (layout.field[slot]) SCANPREP_RETURN_IF_ERROR(source.Get(*layout.field[slot], raw[slot]));
    }
    std::array<float, kScanline> value{};  // the float slots, narrowed
    for (int slot = 0; slot < kFlags; ++slot) value[slot] = NarrowToFloat(raw[slot]);
    // Double coordinates are narrowed relative to their origin once all are read; a finite one
    // beyond float's range from it is an error there, not a missing measurement.
    const bool measured =
        wide != nullptr
            ? std::isfinite(raw[kX]) && std::isfinite(raw[kY]) && std::isfinite(raw[kZ])
            : std::isfinite(value[kX]) && std::isfinite(value[kY]) && std::isfinite(value[kZ]);
    if (!measured) {
      invalid.Count(i);
      continue;
    }
    if (wide != nullptr) {
      wide->Push(raw[kX], raw[kY], raw[kZ]);
    } else {
      cloud.x.push_back(value[kX]);
      cloud.y.push_back(value[kY]);
      cloud.z.push_back(value[kZ]);
    }
    if (normals) {
      cloud.nx.push_back(value[kNx]);
      cloud.ny.push_back(value[kNy]);
      cloud.nz.push_back(value[kNz]);
    }
    if (intensity) cloud.intensity.push_back(value[kIntensity]);
    for (size_t a = 0; a < layout.attribute_fields.size(); ++a) {
      double attribute = 0;
      if (cloud.attributes[a].type == AttributeType::kFloat32Bits) {
        uint32_t bits = 0;
        SCANPREP_RETURN_IF_ERROR(source.GetBits(layout.attribute_fields[a], bits));
        attribute = bits;
      } else {
        SCANPREP_RETURN_IF_ERROR(source.Get(layout.attribute_fields[a], attribute));
      }
      cloud.attributes[a].Append(attribute);
    }
    if (flags) cloud.flags.push_back(static_cast<uint8_t>(raw[kFlags]));
    if (organised) {
      cloud.scanline.push_back(static_cast<uint32_t>(i / header.width));
    } else if (scanline) {
      cloud.scanline.push_back(static_cast<uint32_t>(raw[kScanline]));
    }
  }
  return absl::OkStatus();
}

// The uncompressed field-after-field bytes of a binary_compressed body.
absl::StatusOr<std::string> Decompress(std::string_view body, const Header& header,
                                       const std::string& name) {
  auto error = [&](std::string_view message) {
    return absl::InvalidArgumentError(
        absl::StrCat(name, ": binary_compressed body: ", std::string(message)));
  };
  if (body.size() < 8)
    return error(absl::StrCat("has ", body.size(), " bytes, fewer than its 8-byte size prefix"));
  uint32_t sizes[2];
  std::memcpy(sizes, body.data(), 8);
  const uint64_t compressed = kHostIsBigEndian ? ByteSwapped(sizes[0]) : sizes[0];
  const uint64_t uncompressed = kHostIsBigEndian ? ByteSwapped(sizes[1]) : sizes[1];
  // PCL sizes the file before it compresses, so its files end in zero padding; anything else
  // after the stream is not PCL's and is refused.
  const std::string_view rest = body.substr(8);
  if (compressed > rest.size() ||
      rest.find_first_not_of('\0', compressed) != std::string_view::npos) {
    return error(
        absl::StrCat("declares ", compressed, " compressed bytes but ", rest.size(), " follow",
                     compressed > rest.size() ? "" : ", not all of the rest zero padding"));
  }
  uint64_t record = 0;
  for (const Field& field : header.fields)
    record += field.name == "_" ? 0 : uint64_t{field.size} * field.count;
  if (record != 0 && header.points > uncompressed / record) {
    return error(absl::StrCat("POINTS ", header.points, " of ", record,
                              " bytes need more than the ", uncompressed,
                              " uncompressed bytes it declares"));
  }
  if (header.points * record != uncompressed) {
    return error(absl::StrCat("declares ", uncompressed, " uncompressed bytes but POINTS ",
                              header.points, " of ", record, " bytes are ",
                              header.points * record));
  }
  if (uncompressed > kMaxLzfRatio * compressed) {
    return error(absl::StrCat(compressed, " LZF bytes cannot expand to the ", uncompressed,
                              " declared (at most ", kMaxLzfRatio, "x)"));
  }
  std::string out(uncompressed, '\0');
  if (uncompressed == 0) return out;
  const unsigned got = lzf_decompress(body.data() + 8, static_cast<unsigned>(compressed),
                                      out.data(), static_cast<unsigned>(uncompressed));
  if (got != uncompressed) {
    return error(absl::StrCat("LZF data decompress to ", got, " bytes, not the ", uncompressed,
                              " declared (corrupt data)"));
  }
  return out;
}

void AddMetadataWarnings(const Header& header, const Layout& layout, const std::string& name,
                         PointCloud& cloud, std::vector<std::string>& warnings) {
  if (!layout.unused.empty()) {
    warnings.push_back(absl::StrCat(
        name, ": fields left out: ", absl::StrJoin(layout.unused, ", "),
        " (scanprep reads x y z, normal_x/y/z, intensity, its own flags and scanline, and keeps "
        "any other field of one value up to 4 bytes, or F8, for the output)"));
  }
  constexpr std::array<double, 7> kPclDefault = {0, 0, 0, 1, 0, 0, 0};
  if (!header.viewpoint || *header.viewpoint == kPclDefault) {
    warnings.push_back(absl::StrCat(
        name, ": ",
        header.viewpoint ? "VIEWPOINT is PCL's default 0 0 0 1 0 0 0" : "no VIEWPOINT line",
        ": sensor origin unknown (if the sensor sat at the origin, give camera_position in the job "
        "file)"));
    return;
  }
  const std::array<double, 7>& v = *header.viewpoint;
  cloud.scans.front().camera_position = Eigen::Vector3d(v[0], v[1], v[2]) - cloud.origin;
}

absl::StatusOr<PointCloud> ParsePcd(std::string_view data, const std::string& name,
                                    std::vector<std::string>& warnings) {
  SCANPREP_ASSIGN_OR_RETURN(Header header, pcd::ParseHeader(data, name));
  SCANPREP_ASSIGN_OR_RETURN(Layout layout, MapFields(header, name));
  const std::string_view body = data.substr(header.body_offset);
  PointCloud cloud;
  for (size_t f : layout.attribute_fields) {
    cloud.attributes.push_back(
        {.name = header.fields[f].name, .type = *AttributeTypeOf(header.fields[f])});
  }
  // ParseHeader bounded POINTS by the body (binary_compressed: Decompress does, below).
  if (header.data != Data::kBinaryCompressed) Reserve(header, layout, cloud);
  UnmeasuredPoints invalid("point");
  // F8 coordinates can hold a position far from zero to a precision float cannot.
  const bool double_coordinates = std::any_of(
      layout.field.begin(), layout.field.begin() + 3,
      [&](const auto& f) { return header.fields[*f].type == 'F' && header.fields[*f].size == 8; });
  WideCoordinates wide_coordinates;
  WideCoordinates* wide = double_coordinates ? &wide_coordinates : nullptr;
  absl::Status status;
  if (header.data == Data::kAscii) {
    AsciiSource source(body, header, name);
    status = ReadPoints(header, layout, source, cloud, wide, invalid);
    if (status.ok()) status = source.Finish();
  } else if (header.data == Data::kBinary) {
    BinarySource source(body, header, /*soa=*/false);
    status = ReadPoints(header, layout, source, cloud, wide, invalid);
  } else {
    SCANPREP_ASSIGN_OR_RETURN(std::string bytes, Decompress(body, header, name));
    Reserve(header, layout, cloud);
    BinarySource source(bytes, header, /*soa=*/true);
    status = ReadPoints(header, layout, source, cloud, wide, invalid);
  }
  SCANPREP_RETURN_IF_ERROR(status);
  if (wide != nullptr) SCANPREP_RETURN_IF_ERROR(wide->Narrow(cloud, name));
  SCANPREP_RETURN_IF_ERROR(invalid.Finish(name, cloud.size(), warnings));
  cloud.scans.push_back(ScanMeta{.id = std::filesystem::path(name).stem().string()});
  invalid.Record(cloud.scans);
  AddMetadataWarnings(header, layout, name, cloud, warnings);
  cloud.FinishLoading(std::exchange(cloud.flags, {}));
  return cloud;
}

}  // namespace

absl::StatusOr<PointCloud> ReadPcd(const std::filesystem::path& path,
                                   std::vector<std::string>& warnings) {
  SCANPREP_ASSIGN_OR_RETURN(std::string data, ReadFileToString(path));
  return ParsePcd(data, path.string(), warnings);
}

absl::StatusOr<PointCloud> ReadPcd(std::istream& in, const std::string& name_for_errors,
                                   std::vector<std::string>& warnings) {
  SCANPREP_ASSIGN_OR_RETURN(std::string data, ReadStreamToString(in, name_for_errors));
  return ParsePcd(data, name_for_errors, warnings);
}

}  // namespace scanprep::io
