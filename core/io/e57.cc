// SPDX-License-Identifier: Apache-2.0
// E57 reader: the paged file is checked and read as one logical byte string, the XML section
// says what each scan holds, and each scan's compressed vector is split into one byte stream per
// field, decoded, and assembled into points.
#include "core/io/e57.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <numeric>
#include <optional>

#include <Eigen/Geometry>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "core/base/free_memory.h"
#include "core/base/status_macros.h"
#include "core/io/byte_order.h"
#include "core/io/e57_xml.h"
#include "core/io/local_frame.h"
#include "core/io/read_file.h"
#include "core/io/unmeasured_points.h"

namespace scanprep::io {
namespace {

using e57::XmlNode;

constexpr size_t kFileHeaderBytes = 48;
constexpr size_t kChecksumBytes = 4;
constexpr size_t kSectionHeaderBytes = 32;

template <class T>
T Load(const char* p) {
  T value;
  std::memcpy(&value, p, sizeof(T));
  return kHostIsBigEndian ? ByteSwapped(value) : value;
}

// The file without its page checksums, each checked (stored big-endian at the end of its page).
absl::StatusOr<std::string> LogicalBytes(std::string_view file, uint64_t page_size,
                                         const std::string& name) {
  const uint64_t payload = page_size - kChecksumBytes;
  std::string logical;
  logical.reserve(file.size() / page_size * payload);
  for (uint64_t page = 0; page * page_size < file.size(); ++page) {
    const char* p = file.data() + page * page_size;
    uint32_t stored;
    std::memcpy(&stored, p + payload, sizeof stored);
    if (!kHostIsBigEndian) stored = ByteSwapped(stored);
    if (E57PageChecksum(std::string_view(p, payload)) != stored) {
      return absl::InvalidArgumentError(absl::StrCat(name, ": page ", page, " (bytes ",
                                                     page * page_size,
                                                     "..) fails its CRC-32C: "
                                                     "the file is damaged"));
    }
    logical.append(p, payload);
  }
  return logical;
}

// A physical offset as an offset into the logical bytes.
absl::StatusOr<uint64_t> ToLogical(uint64_t physical, uint64_t page_size, uint64_t logical_size,
                                   const std::string& what) {
  const uint64_t payload = page_size - kChecksumBytes;
  const uint64_t in_page = physical % page_size;
  const uint64_t logical = physical / page_size * payload + in_page;
  if (in_page >= payload || logical >= logical_size) {
    return absl::InvalidArgumentError(
        absl::StrCat(what, " at physical offset ", physical, " is outside the file's data"));
  }
  return logical;
}

absl::StatusOr<double> Number(const XmlNode* node, double fallback, const std::string& what) {
  if (node == nullptr) return fallback;
  std::string_view text = node->text;
  while (!text.empty() && std::isspace(static_cast<unsigned char>(text.front()))) {
    text.remove_prefix(1);
  }
  while (!text.empty() && std::isspace(static_cast<unsigned char>(text.back()))) {
    text.remove_suffix(1);
  }
  if (text.empty()) return fallback;  // E57 writes <versionMinor type="Integer"/> for 0
  double value = 0;
  if (!absl::SimpleAtod(absl::string_view(text.data(), text.size()), &value) ||
      !std::isfinite(value)) {
    return absl::InvalidArgumentError(
        absl::StrCat(what, ": '", std::string(text), "' is not a number"));
  }
  return value;
}

// One field of a compressed vector's prototype and, once read, its bytes.
struct Field {
  enum Kind { kFloat, kInteger, kScaledInteger } kind = kFloat;
  std::string name;
  bool single = false;  // Float precision
  int64_t minimum = INT64_MIN, maximum = INT64_MAX;
  double scale = 1, offset = 0;
  int bits = 0;        // per record, for the integer kinds
  std::string stream;  // the field's bytes from every data packet, in order
};

absl::StatusOr<int64_t> IntAttribute(const XmlNode& node, std::string_view attribute,
                                     int64_t fallback, const std::string& what) {
  const std::string text = node.Attribute(attribute);
  if (text.empty()) return fallback;
  int64_t value = 0;
  if (!absl::SimpleAtoi(text, &value)) {
    return absl::InvalidArgumentError(
        absl::StrCat(what, ": ", std::string(attribute), "='", text, "' is not an integer"));
  }
  return value;
}

absl::StatusOr<std::vector<Field>> Prototype(const XmlNode& points, const std::string& what) {
  const XmlNode* prototype = points.Child("prototype");
  if (prototype == nullptr || prototype->children.empty()) {
    return absl::InvalidArgumentError(absl::StrCat(what, ": points have no prototype"));
  }
  if (const XmlNode* codecs = points.Child("codecs"); codecs && !codecs->children.empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat(what, ": points use a codec other than the standard bitPackCodec"));
  }
  std::vector<Field> fields;
  for (const XmlNode& node : prototype->children) {
    Field f;
    f.name = node.name;
    const std::string where = absl::StrCat(what, " field ", f.name);
    const std::string type = node.Attribute("type");
    if (type == "Float") {
      f.kind = Field::kFloat;
      f.single = node.Attribute("precision", "double") == "single";
    } else if (type == "Integer" || type == "ScaledInteger") {
      f.kind = type == "Integer" ? Field::kInteger : Field::kScaledInteger;
      SCANPREP_ASSIGN_OR_RETURN(f.minimum, IntAttribute(node, "minimum", INT64_MIN, where));
      SCANPREP_ASSIGN_OR_RETURN(f.maximum, IntAttribute(node, "maximum", INT64_MAX, where));
      if (f.maximum < f.minimum) {
        return absl::InvalidArgumentError(absl::StrCat(where, ": maximum below minimum"));
      }
      const uint64_t range = static_cast<uint64_t>(f.maximum) - static_cast<uint64_t>(f.minimum);
      f.bits = range == 0 ? 0 : 64 - std::countl_zero(range);
      if (f.kind == Field::kScaledInteger) {
        auto attribute = [&](std::string_view name, double fallback) -> absl::StatusOr<double> {
          const std::string text = node.Attribute(name);
          double value = fallback;
          if (!text.empty() && (!absl::SimpleAtod(text, &value) || !std::isfinite(value))) {
            return absl::InvalidArgumentError(
                absl::StrCat(where, ": ", std::string(name), "='", text, "'"));
          }
          return value;
        };
        SCANPREP_ASSIGN_OR_RETURN(f.scale, attribute("scale", 1));
        SCANPREP_ASSIGN_OR_RETURN(f.offset, attribute("offset", 0));
      }
    } else {
      return absl::InvalidArgumentError(absl::StrCat(
          where, ": type '", type, "' cannot be read (Float, Integer, ScaledInteger)"));
    }
    fields.push_back(std::move(f));
  }
  return fields;
}

// Bits one record takes in `f`'s stream.
uint64_t RecordBits(const Field& f) {
  return f.kind == Field::kFloat ? (f.single ? 32 : 64) : f.bits;
}

// Splits the data packets of the compressed vector whose section starts at `section` into one
// stream per field. Index and empty packets are stepped over.
absl::Status ReadStreams(std::string_view logical, uint64_t page_size, uint64_t section,
                         std::vector<Field>& fields, const std::string& what) {
  if (section + kSectionHeaderBytes > logical.size() || logical[section] != 1) {
    return absl::InvalidArgumentError(
        absl::StrCat(what, ": no compressed-vector section at its fileOffset"));
  }
  const uint64_t length = Load<uint64_t>(logical.data() + section + 8);
  if (length < kSectionHeaderBytes || length > logical.size() - section) {
    return absl::InvalidArgumentError(
        absl::StrCat(what, ": section length ", length, " runs past the end of the file"));
  }
  const uint64_t end = section + length;
  SCANPREP_ASSIGN_OR_RETURN(uint64_t at,
                            ToLogical(Load<uint64_t>(logical.data() + section + 16), page_size,
                                      logical.size(), absl::StrCat(what, ": data packets")));
  while (at + 6 <= end) {
    const char* p = logical.data() + at;
    const uint8_t type = static_cast<uint8_t>(p[0]);
    const uint64_t packet = uint64_t{Load<uint16_t>(p + 2)} + 1;
    if (at + packet > end) {
      return absl::InvalidArgumentError(
          absl::StrCat(what, ": a packet at byte ", at, " runs past its section"));
    }
    if (type == 1) {  // data; 0 = index, 2 = empty
      const uint16_t count = Load<uint16_t>(p + 4);
      if (count != fields.size()) {
        return absl::InvalidArgumentError(absl::StrCat(what, ": a data packet holds ", count,
                                                       " streams for ", fields.size(), " fields"));
      }
      uint64_t offset = 6 + 2 * uint64_t{count};
      if (offset > packet) {
        return absl::InvalidArgumentError(
            absl::StrCat(what, ": a data packet at byte ", at, " is shorter than its header"));
      }
      for (size_t k = 0; k < fields.size(); ++k) {
        const uint64_t bytes = Load<uint16_t>(p + 6 + 2 * k);
        if (offset + bytes > packet) {
          return absl::InvalidArgumentError(absl::StrCat(what, ": a data packet at byte ", at,
                                                         " overflows in field ", fields[k].name));
        }
        fields[k].stream.append(p + offset, bytes);
        offset += bytes;
      }
    } else if (type > 2) {
      return absl::InvalidArgumentError(
          absl::StrCat(what, ": unknown packet type ", int{type}, " at byte ", at));
    }
    at += packet;
  }
  return absl::OkStatus();
}

// The field's `count` values. The stream must hold them all.
absl::StatusOr<std::vector<double>> Decode(Field& f, uint64_t count, const std::string& what) {
  const uint64_t bits = RecordBits(f);
  if (bits > 0 && f.stream.size() * 8 / bits < count) {
    return absl::InvalidArgumentError(absl::StrCat(what, " field ", f.name, ": ", count,
                                                   " records declared, its data holds ",
                                                   f.stream.size() * 8 / bits));
  }
  std::vector<double> values(count);
  const char* s = f.stream.data();
  if (f.kind == Field::kFloat) {
    for (uint64_t i = 0; i < count; ++i) {
      values[i] = f.single ? Load<float>(s + 4 * i) : Load<double>(s + 8 * i);
    }
    return values;
  }
  f.stream.append(16, '\0');  // a 128-bit window at the last record stays inside
  s = f.stream.data();
  using u128 = unsigned __int128;
  const u128 mask = (static_cast<u128>(1) << bits) - 1;
  for (uint64_t i = 0; i < count; ++i) {
    const uint64_t bit = i * bits;
    u128 window = 0;
    for (int b = 15; b >= 0; --b) {
      window = (window << 8) | static_cast<uint8_t>(s[bit / 8 + b]);
    }
    const uint64_t raw = static_cast<uint64_t>((window >> (bit % 8)) & mask);
    const int64_t value = static_cast<int64_t>(static_cast<uint64_t>(f.minimum) + raw);
    // The bit width rounds the range up to a power of two (and a 64-bit one wraps); a record
    // outside the prototype's range is a broken file, which its attribute type could not hold.
    if (value < f.minimum || value > f.maximum) {
      return absl::InvalidArgumentError(absl::StrCat(what, " field ", f.name, " record ", i, ": ",
                                                     value, " is outside its range [", f.minimum,
                                                     ", ", f.maximum, "]"));
    }
    values[i] = f.kind == Field::kInteger ? static_cast<double>(value)
                                          : static_cast<double>(value) * f.scale + f.offset;
  }
  return values;
}

// One scan's pose: E57 rotation quaternion (w, x, y, z) and translation, local -> file frame.
struct Pose {
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  bool present = false;
};

absl::StatusOr<Pose> ReadPose(const XmlNode& scan, const std::string& what) {
  Pose pose;
  const XmlNode* node = scan.Child("pose");
  if (node == nullptr) return pose;
  pose.present = true;
  if (const XmlNode* r = node->Child("rotation")) {
    std::array<double, 4> q{};
    const char* names[] = {"w", "x", "y", "z"};
    for (int k = 0; k < 4; ++k) {
      SCANPREP_ASSIGN_OR_RETURN(q[k], Number(r->Child(names[k]), k == 0 ? 1.0 : 0.0,
                                             absl::StrCat(what, " pose rotation ", names[k])));
    }
    pose.rotation = Eigen::Quaterniond(q[0], q[1], q[2], q[3]);
    const double norm = pose.rotation.norm();
    if (std::abs(norm - 1) > 1e-3) {
      return absl::InvalidArgumentError(
          absl::StrCat(what, ": pose rotation is not a unit quaternion (norm ", norm, ")"));
    }
    pose.rotation.normalize();
  }
  if (const XmlNode* t = node->Child("translation")) {
    const char* names[] = {"x", "y", "z"};
    for (int k = 0; k < 3; ++k) {
      SCANPREP_ASSIGN_OR_RETURN(
          pose.translation[k],
          Number(t->Child(names[k]), 0.0, absl::StrCat(what, " pose translation ", names[k])));
    }
  }
  return pose;
}

// What one scan contributes, before the scans are joined; its positions go to the file's
// WideCoordinates.
struct ScanPoints {
  uint64_t count = 0;  // valid points
  std::vector<float> intensity;
  std::vector<PointAttribute> attributes;  // the other fields (colour, time stamps…)
  std::vector<uint32_t> line;              // empty without a grid
  bool has_intensity = false;
};

// The scanline of each point from a grid's row and column indices, with the points of each
// line put in the order of the other index. Returns the order to take the records in.
absl::StatusOr<std::vector<uint32_t>> GridLines(const std::vector<double>& row,
                                                const std::vector<double>& column,
                                                std::vector<uint32_t>& line,
                                                const std::string& what) {
  const size_t n = row.size();
  size_t row_changes = 0, column_changes = 0;
  for (size_t i = 1; i < n; ++i) {
    row_changes += row[i] != row[i - 1];
    column_changes += column[i] != column[i - 1];
  }
  const std::vector<double>& along = column_changes <= row_changes ? row : column;
  const std::vector<double>& lines = column_changes <= row_changes ? column : row;
  for (double l : lines) {
    if (!(l >= 0 && l < double{1u << 30})) {  // lines of all scans are numbered in 32 bits
      return absl::InvalidArgumentError(
          absl::StrCat(what, ": grid index ", l, " outside 0..2^30 (rowIndex/columnIndex)"));
    }
  }
  std::vector<uint32_t> order(n);
  std::iota(order.begin(), order.end(), 0u);
  std::stable_sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) {
    return lines[a] != lines[b] ? lines[a] < lines[b] : along[a] < along[b];
  });
  line.resize(n);
  for (size_t i = 0; i < n; ++i) line[i] = static_cast<uint32_t>(lines[order[i]]);
  return order;
}

// A scan's compressed vector decoded: its prototype's fields (their streams freed once decoded)
// and one column of values per field.
struct ScanColumns {
  std::vector<Field> fields;
  std::vector<std::vector<double>> values;
  uint64_t count = 0;  // records

  // The values of the field named `name`, or nullptr when the scan has none.
  const std::vector<double>* Find(std::string_view name) const {
    for (size_t k = 0; k < fields.size(); ++k) {
      if (fields[k].name == name) return &values[k];
    }
    return nullptr;
  }
};

// The scan's points as its prototype describes them, each field decoded into a column. The
// record count is checked against the file before anything is allocated for it.
absl::StatusOr<ScanColumns> DecodeColumns(std::string_view logical, uint64_t page_size,
                                          const XmlNode& scan, const std::string& what) {
  const XmlNode* points = scan.Child("points");
  if (points == nullptr || points->Attribute("type") != "CompressedVector") {
    return absl::InvalidArgumentError(absl::StrCat(what, ": no points (CompressedVector)"));
  }
  SCANPREP_ASSIGN_OR_RETURN(int64_t count, IntAttribute(*points, "recordCount", -1, what));
  SCANPREP_ASSIGN_OR_RETURN(int64_t offset, IntAttribute(*points, "fileOffset", -1, what));
  if (count < 0 || offset < 0 || count > UINT32_MAX) {
    return absl::InvalidArgumentError(
        absl::StrCat(what, ": points need a recordCount (at most 2^32-1) and a fileOffset"));
  }
  ScanColumns columns{.count = static_cast<uint64_t>(count)};
  SCANPREP_ASSIGN_OR_RETURN(columns.fields, Prototype(*points, what));
  // Before decoding allocates count values per field: the widest field must fit the file.
  uint64_t widest = 0;
  for (const Field& f : columns.fields) widest = std::max(widest, RecordBits(f));
  if (widest == 0 || columns.count > logical.size() * 8 / widest) {
    return absl::InvalidArgumentError(
        absl::StrCat(what, ": ", count, " records cannot fit in a ", logical.size(), "-byte file"));
  }
  SCANPREP_ASSIGN_OR_RETURN(uint64_t section,
                            ToLogical(static_cast<uint64_t>(offset), page_size, logical.size(),
                                      absl::StrCat(what, ": points")));
  SCANPREP_RETURN_IF_ERROR(ReadStreams(logical, page_size, section, columns.fields, what));
  for (Field& f : columns.fields) {
    SCANPREP_ASSIGN_OR_RETURN(std::vector<double> values, Decode(f, columns.count, what));
    columns.values.push_back(std::move(values));
    FreeMemory(f.stream);
  }
  return columns;
}

// The columns the points are made of: cartesian or spherical coordinates, and what else a point
// carries.
struct PointColumns {
  const std::vector<double>*x = nullptr, *y = nullptr, *z = nullptr;
  const std::vector<double>*range = nullptr, *azimuth = nullptr, *elevation = nullptr;
  const std::vector<double>*invalid = nullptr, *intensity = nullptr;
  const std::vector<double>*row = nullptr, *column = nullptr;  // grid indices
  std::vector<size_t> others;  // the scan's other fields: kept as attributes for the output

  bool cartesian() const { return x && y && z; }

  // Record i's position in the scan's own frame.
  Eigen::Vector3d Position(uint32_t i) const {
    if (cartesian()) return {(*x)[i], (*y)[i], (*z)[i]};
    const double r = (*range)[i], a = (*azimuth)[i], e = (*elevation)[i];
    return {r * std::cos(e) * std::cos(a), r * std::cos(e) * std::sin(a), r * std::sin(e)};
  }
};

// The attribute type that holds every value of `field` as its prototype bounds them.
AttributeType TypeOf(const Field& field) {
  if (field.kind == Field::kFloat) {
    return field.single ? AttributeType::kFloat32 : AttributeType::kFloat64;
  }
  if (field.kind == Field::kScaledInteger) return AttributeType::kFloat64;
  if (field.minimum >= 0 && field.maximum <= UINT8_MAX) return AttributeType::kUint8;
  if (field.minimum >= 0 && field.maximum <= UINT16_MAX) return AttributeType::kUint16;
  if (field.minimum >= INT32_MIN && field.maximum <= INT32_MAX) return AttributeType::kInt32;
  if (field.minimum >= 0 && field.maximum <= UINT32_MAX) return AttributeType::kUint32;
  return AttributeType::kFloat64;  // beyond 2^53 a double rounds: E57 fields that wide are rare
}

// Picks the point columns out of the scan's, refused without a full set of coordinates.
absl::StatusOr<PointColumns> PickColumns(const ScanColumns& columns, const std::string& what) {
  PointColumns c{.x = columns.Find("cartesianX"),
                 .y = columns.Find("cartesianY"),
                 .z = columns.Find("cartesianZ"),
                 .range = columns.Find("sphericalRange"),
                 .azimuth = columns.Find("sphericalAzimuth"),
                 .elevation = columns.Find("sphericalElevation")};
  if (!c.cartesian() && !(c.range && c.azimuth && c.elevation)) {
    return absl::InvalidArgumentError(absl::StrCat(
        what, ": points have neither cartesianX/Y/Z nor sphericalRange/Azimuth/Elevation"));
  }
  c.invalid = columns.Find(c.cartesian() ? "cartesianInvalidState" : "sphericalInvalidState");
  c.intensity = columns.Find("intensity");
  c.row = columns.Find("rowIndex");
  c.column = columns.Find("columnIndex");
  for (size_t k = 0; k < columns.fields.size(); ++k) {
    const Field& f = columns.fields[k];
    static const char* kUsed[] = {"cartesianX",
                                  "cartesianY",
                                  "cartesianZ",
                                  "sphericalRange",
                                  "sphericalAzimuth",
                                  "sphericalElevation",
                                  "cartesianInvalidState",
                                  "sphericalInvalidState",
                                  "intensity",
                                  "rowIndex",
                                  "columnIndex"};
    if (std::find(std::begin(kUsed), std::end(kUsed), f.name) == std::end(kUsed)) {
      c.others.push_back(k);
    }
  }
  return c;
}

// The scan's valid points, moved by its pose in double, are appended to `positions`; the others
// are counted in `unmeasured` as records of `label`.
absl::StatusOr<ScanPoints> ReadScan(std::string_view logical, uint64_t page_size,
                                    const XmlNode& scan, const Pose& pose, const std::string& what,
                                    const std::string& label, size_t scan_index,
                                    WideCoordinates& positions, UnmeasuredPoints& unmeasured) {
  SCANPREP_ASSIGN_OR_RETURN(const ScanColumns columns,
                            DecodeColumns(logical, page_size, scan, what));
  SCANPREP_ASSIGN_OR_RETURN(const PointColumns c, PickColumns(columns, what));
  ScanPoints out;
  out.has_intensity = c.intensity != nullptr;
  for (size_t k : c.others) {
    out.attributes.push_back({.name = columns.fields[k].name, .type = TypeOf(columns.fields[k])});
  }
  std::vector<uint32_t> order(columns.count);
  std::iota(order.begin(), order.end(), 0u);
  std::vector<uint32_t> line;
  if (c.row && c.column) {
    SCANPREP_ASSIGN_OR_RETURN(order, GridLines(*c.row, *c.column, line, what));
  }
  positions.Reserve(positions.size() + order.size());  // no doubling of 24 B per point
  for (size_t k = 0; k < order.size(); ++k) {
    const uint32_t i = order[k];
    Eigen::Vector3d p = c.Position(i);
    if ((c.invalid && (*c.invalid)[i] != 0) || !p.allFinite()) {
      unmeasured.Count(i, label, scan_index);
      continue;
    }
    // Kept in double: a georeferenced pose (a UTM easting of 5e5 m) would leave float a 3 cm
    // lattice; the file's local origin is taken off before narrowing.
    p = pose.rotation * p + pose.translation;
    positions.Push(p.x(), p.y(), p.z());
    ++out.count;
    if (c.intensity) out.intensity.push_back(static_cast<float>((*c.intensity)[i]));
    for (size_t a = 0; a < c.others.size(); ++a) {
      out.attributes[a].Append(columns.values[c.others[a]][i]);
    }
    if (!line.empty()) out.line.push_back(line[k]);
  }
  return out;
}

}  // namespace

uint32_t E57PageChecksum(std::string_view payload) {
  static const std::array<uint32_t, 256> table = [] {
    std::array<uint32_t, 256> t{};
    for (uint32_t i = 0; i < 256; ++i) {
      uint32_t c = i;
      for (int k = 0; k < 8; ++k) c = (c >> 1) ^ ((c & 1) ? 0x82F63B78u : 0);
      t[i] = c;
    }
    return t;
  }();
  uint32_t crc = 0xFFFFFFFFu;
  for (char byte : payload) crc = table[(crc ^ static_cast<uint8_t>(byte)) & 0xFF] ^ (crc >> 8);
  return crc ^ 0xFFFFFFFFu;
}

namespace {

// An E57 file's logical bytes (every page's checksum checked and taken off) and its XML section
// as a tree.
struct E57File {
  std::string logical;
  uint64_t page_size = 0;
  XmlNode root;
};

// The file header checked against the file, the pages checked, and the XML section parsed.
absl::StatusOr<E57File> OpenE57(std::string_view file, const std::string& name) {
  if (file.size() < kFileHeaderBytes || file.substr(0, 8) != "ASTM-E57") {
    return absl::InvalidArgumentError(
        absl::StrCat(name, ": not an E57 file (no 'ASTM-E57' signature)"));
  }
  const uint32_t major = Load<uint32_t>(file.data() + 8);
  const uint64_t physical_length = Load<uint64_t>(file.data() + 16);
  const uint64_t xml_offset = Load<uint64_t>(file.data() + 24);
  const uint64_t xml_length = Load<uint64_t>(file.data() + 32);
  E57File e57_file{.page_size = Load<uint64_t>(file.data() + 40)};
  if (major != 1) {
    return absl::InvalidArgumentError(
        absl::StrCat(name, ": E57 version ", major, " (this reader knows version 1)"));
  }
  if (e57_file.page_size < 64 || e57_file.page_size > (1u << 20) ||
      physical_length != file.size() || file.size() % e57_file.page_size != 0) {
    return absl::InvalidArgumentError(absl::StrCat(
        name, ": header says ", physical_length, " bytes in pages of ", e57_file.page_size,
        ", the file has ", file.size(), " (truncated or not E57)"));
  }
  SCANPREP_ASSIGN_OR_RETURN(e57_file.logical, LogicalBytes(file, e57_file.page_size, name));
  SCANPREP_ASSIGN_OR_RETURN(uint64_t xml_at,
                            ToLogical(xml_offset, e57_file.page_size, e57_file.logical.size(),
                                      absl::StrCat(name, ": XML section")));
  if (xml_length > e57_file.logical.size() - xml_at) {
    return absl::InvalidArgumentError(absl::StrCat(name, ": XML section of ", xml_length,
                                                   " bytes runs past the end of the file"));
  }
  SCANPREP_ASSIGN_OR_RETURN(
      e57_file.root,
      e57::ParseXml(std::string_view(e57_file.logical).substr(xml_at, xml_length), name));
  return e57_file;
}

// What reading the scans of a file gathers besides their points, for the cloud and the warnings.
struct ScansRead {
  std::vector<ScanPoints> points;  // per scan
  WideCoordinates positions;       // every scan's valid points, in the file's frame
  UnmeasuredPoints unmeasured{"record"};
  std::vector<std::string> unused;   // fields not in every scan alike (repeats included)
  std::vector<std::string> no_pose;  // ids of the scans without a pose
};

// Every data3D scan: its ScanMeta (id, sensor origin from its pose) appended to `metas`, its
// points to `read`.
absl::Status ReadScans(const E57File& e57_file, const XmlNode& data3d, const std::string& name,
                       std::vector<ScanMeta>& metas, ScansRead& read) {
  for (size_t s = 0; s < data3d.children.size(); ++s) {
    const XmlNode& node = data3d.children[s];
    const XmlNode* title = node.Child("name");
    ScanMeta meta;
    meta.id = title && !title->text.empty() ? title->text : absl::StrCat("data3D ", s);
    const std::string what = absl::StrCat(name, ": scan ", s, " '", meta.id, "'");
    SCANPREP_ASSIGN_OR_RETURN(Pose pose, ReadPose(node, what));
    if (pose.present) {
      meta.camera_position = pose.translation;
    } else {
      read.no_pose.push_back(meta.id);
    }
    SCANPREP_ASSIGN_OR_RETURN(
        ScanPoints points,
        ReadScan(e57_file.logical, e57_file.page_size, node, pose, what,
                 absl::StrCat("scan ", s, " '", meta.id, "'"), s, read.positions, read.unmeasured));
    metas.push_back(std::move(meta));
    read.points.push_back(std::move(points));
  }
  return absl::OkStatus();
}

// The scans' per-point arrays joined into the cloud's, each scan's emptied as it goes: the scan
// index, and intensity and scanlines when every scan has them.
absl::Status JoinScans(std::vector<ScanPoints>& scans, bool intensity, const std::string& name,
                       PointCloud& cloud) {
  const bool lines =
      std::all_of(scans.begin(), scans.end(), [](const ScanPoints& s) { return !s.line.empty(); });
  uint64_t line_base = 0;
  for (size_t s = 0; s < scans.size(); ++s) {
    ScanPoints& p = scans[s];
    cloud.scan.resize(cloud.scan.size() + p.count, static_cast<uint32_t>(s));
    if (intensity)
      cloud.intensity.insert(cloud.intensity.end(), p.intensity.begin(), p.intensity.end());
    if (lines) {
      // Lines are numbered per file, so two scans' lines never share a number.
      uint64_t top = 0;
      for (uint32_t l : p.line) {
        cloud.scanline.push_back(static_cast<uint32_t>(line_base + l));
        top = std::max<uint64_t>(top, l + 1);
      }
      line_base += top;
      if (line_base > UINT32_MAX) {
        return absl::InvalidArgumentError(
            absl::StrCat(name, ": the scans' grids hold more than 2^32 lines"));
      }
    }
    p = {};
  }
  return absl::OkStatus();
}

// Moves the scans' sensor origins by the cloud's origin: positions, like the points, are
// relative to it.
absl::Status CameraPositionsToLocal(const std::string& name, PointCloud& cloud) {
  for (ScanMeta& meta : cloud.scans) {
    if (!meta.camera_position) continue;
    *meta.camera_position -= cloud.origin;
    if (!meta.camera_position->allFinite()) {  // a pose ~1e308 m from the other scans' points
      return absl::InvalidArgumentError(absl::StrCat(
          name, ": scan '", meta.id, "' pose translation is beyond double's range of the points"));
    }
  }
  return absl::OkStatus();
}

// Warnings for what the cloud lacks that the file might have given: sensor origins, fields no
// point uses, intensity that only some scans have.
void WarnLeftOut(const std::string& name, ScansRead& read, bool intensity,
                 std::vector<std::string>& warnings) {
  if (!read.no_pose.empty()) {
    warnings.push_back(absl::StrCat(name, ": no pose (scanner origin) for ",
                                    absl::StrJoin(read.no_pose, ", "),
                                    ": give camera_position in a job file"));
  }
  std::vector<std::string>& unused = read.unused;
  std::sort(unused.begin(), unused.end());
  unused.erase(std::unique(unused.begin(), unused.end()), unused.end());
  if (!unused.empty()) {
    warnings.push_back(absl::StrCat(
        name, ": fields left out (not in every scan, of one type): ", absl::StrJoin(unused, ", ")));
  }
  if (!intensity && std::any_of(read.points.begin(), read.points.end(),
                                [](const ScanPoints& s) { return s.has_intensity; })) {
    warnings.push_back(absl::StrCat(name, ": intensity left out (not every scan has it)"));
  }
}

}  // namespace

absl::StatusOr<PointCloud> ReadE57Bytes(std::string_view file, const std::string& name,
                                        std::vector<std::string>& warnings) {
  SCANPREP_ASSIGN_OR_RETURN(const E57File e57_file, OpenE57(file, name));
  const XmlNode* data3d = e57_file.root.Child("data3D");
  if (e57_file.root.name != "e57Root" || data3d == nullptr || data3d->children.empty()) {
    return absl::InvalidArgumentError(absl::StrCat(name, ": no data3D scan in the file"));
  }
  PointCloud cloud;
  ScansRead read;
  SCANPREP_RETURN_IF_ERROR(ReadScans(e57_file, *data3d, name, cloud.scans, read));
  const bool intensity = std::all_of(read.points.begin(), read.points.end(),
                                     [](const ScanPoints& s) { return s.has_intensity; });
  std::vector<const std::vector<PointAttribute>*> parts;
  for (const ScanPoints& scan : read.points) parts.push_back(&scan.attributes);
  std::vector<std::vector<std::string>> left_out;
  cloud.attributes = JoinAttributes(parts, left_out);
  for (std::vector<std::string>& names : left_out) {
    read.unused.insert(read.unused.end(), names.begin(), names.end());
  }
  SCANPREP_RETURN_IF_ERROR(JoinScans(read.points, intensity, name, cloud));
  SCANPREP_RETURN_IF_ERROR(read.unmeasured.Finish(name, cloud.scan.size(), warnings));
  read.unmeasured.Record(cloud.scans);
  SCANPREP_RETURN_IF_ERROR(read.positions.Narrow(cloud, name));
  SCANPREP_RETURN_IF_ERROR(CameraPositionsToLocal(name, cloud));
  WarnLeftOut(name, read, intensity, warnings);
  cloud.FinishLoading();
  return cloud;
}

absl::StatusOr<PointCloud> ReadE57(const std::filesystem::path& path,
                                   std::vector<std::string>& warnings) {
  SCANPREP_ASSIGN_OR_RETURN(std::string bytes, ReadFileToString(path));
  return ReadE57Bytes(bytes, path.string(), warnings);
}

absl::StatusOr<PointCloud> ReadE57(std::istream& in, const std::string& name_for_errors,
                                   std::vector<std::string>& warnings) {
  SCANPREP_ASSIGN_OR_RETURN(std::string bytes, ReadStreamToString(in, name_for_errors));
  return ReadE57Bytes(bytes, name_for_errors, warnings);
}

}  // namespace scanprep::io
