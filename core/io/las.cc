// SPDX-License-Identifier: Apache-2.0
// LAS reader: the public header fixes the layout, the records are decoded in one pass that also
// splits the scanlines.
#include "core/io/las.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/base/status_macros.h"
#include "core/io/byte_order.h"
#include "core/io/float_narrowing.h"
#include "core/io/local_frame.h"
#include "core/io/read_file.h"
#include "core/io/unmeasured_points.h"

namespace scanprep::io {
namespace {

constexpr size_t kMinHeaderBytes = 227;  // LAS 1.0 to 1.2
constexpr size_t kHeader14Bytes = 375;
// The smallest record of each point data format 0..10.
constexpr uint16_t kRecordBytes[] = {20, 28, 26, 34, 57, 63, 30, 36, 38, 59, 67};

template <class T>
T Load(const char* p) {
  T value;
  std::memcpy(&value, p, sizeof(T));
  return kHostIsBigEndian ? ByteSwapped(value) : value;
}

absl::Status Laz(const std::string& name) {
  return absl::InvalidArgumentError(
      absl::StrCat(name,
                   " is LAZ-compressed; no LASzip decoder is packaged for Debian 12: decompress it "
                   "first (e.g. `laszip -i f.laz -o f.las` or `pdal translate f.laz f.las`)"));
}

// Where the point records end: at the waveform packets (LAS 1.3, formats 4, 5, 9, 10) or the
// extended VLRs (LAS 1.4) when the header places them after the points, else at the file's end.
uint64_t PointDataEnd(std::string_view file, int minor, uint16_t header_size, uint32_t offset) {
  uint64_t end = file.size();
  auto limit = [&](uint64_t start) {
    if (start > offset && start < end) end = start;
  };
  if (minor >= 3 && header_size >= 235) limit(Load<uint64_t>(file.data() + 227));
  if (minor >= 4 && header_size >= kHeader14Bytes && Load<uint32_t>(file.data() + 243) > 0) {
    limit(Load<uint64_t>(file.data() + 235));
  }
  return end;
}

// The local origin (LocalOrigin) of the records' coordinates: one pass over their integers
// first, so that each is narrowed to float once, relative to it.
Eigen::Vector3d RecordsOrigin(const char* records, uint64_t count, uint16_t record,
                              const double scale[3], const double shift[3]) {
  int32_t lo[3], hi[3];
  for (int k = 0; k < 3; ++k) lo[k] = hi[k] = Load<int32_t>(records + 4 * k);
  for (uint64_t i = 1; i < count; ++i) {
    for (int k = 0; k < 3; ++k) {
      const int32_t v = Load<int32_t>(records + i * record + 4 * k);
      lo[k] = std::min(lo[k], v), hi[k] = std::max(hi[k], v);
    }
  }
  Eigen::Vector3d min, max;
  for (int k = 0; k < 3; ++k) {
    const double a = lo[k] * scale[k] + shift[k], b = hi[k] * scale[k] + shift[k];
    min[k] = std::min(a, b), max[k] = std::max(a, b);  // a scale may be negative
  }
  return LocalOrigin(min, max);
}

// What the public header says about the point records, checked against the file.
struct LasLayout {
  int major = 0, minor = 0, format = 0;
  uint16_t header_size = 0;
  uint16_t record = 0;  // bytes per point record
  uint32_t offset = 0;  // where the records start
  uint64_t count = 0;
  double scale[3] = {}, shift[3] = {};  // a coordinate is its integer * scale + shift
};

// The coordinate grid of every axis: a record's integers mean nothing without a finite, non-zero
// scale and a finite offset.
absl::Status ReadGrid(const char* h, const std::string& name, LasLayout& las) {
  for (int k = 0; k < 3; ++k) {
    las.scale[k] = Load<double>(h + 131 + 8 * k);
    las.shift[k] = Load<double>(h + 155 + 8 * k);
    if (!std::isfinite(las.scale[k]) || las.scale[k] == 0 || !std::isfinite(las.shift[k])) {
      return absl::InvalidArgumentError(
          absl::StrCat(name, ": ", std::string(1, "xyz"[k]), " scale ", las.scale[k],
                       " and offset ", las.shift[k], " (a scale must be finite and non-zero)"));
    }
  }
  return absl::OkStatus();
}

// The header's version, point format, record size, point count and grid, refused unless they fit
// together and the file; the records are decoded only after this.
absl::StatusOr<LasLayout> ReadLayout(std::string_view file, const std::string& name) {
  if (file.size() < kMinHeaderBytes || file.substr(0, 4) != "LASF") {
    return absl::InvalidArgumentError(absl::StrCat(name, ": not a LAS file (no 'LASF' signature)"));
  }
  const char* h = file.data();
  LasLayout las{.major = static_cast<uint8_t>(h[24]),
                .minor = static_cast<uint8_t>(h[25]),
                .header_size = Load<uint16_t>(h + 94),
                .record = Load<uint16_t>(h + 105),
                .offset = Load<uint32_t>(h + 96)};
  const uint8_t format_id = static_cast<uint8_t>(h[104]);
  if (las.major != 1 || las.minor > 4) {
    return absl::InvalidArgumentError(absl::StrCat(name, ": LAS version ", las.major, ".",
                                                   las.minor, " (this reader knows 1.0 to 1.4)"));
  }
  if ((format_id & 0xC0) != 0) return Laz(name);
  las.format = format_id;
  if (las.format > 10) {
    return absl::InvalidArgumentError(
        absl::StrCat(name, ": point data format ", las.format, " (LAS defines 0 to 10)"));
  }
  if (las.record < kRecordBytes[las.format]) {
    return absl::InvalidArgumentError(absl::StrCat(name, ": point records of ", las.record,
                                                   " bytes, format ", las.format,
                                                   " needs at least ", kRecordBytes[las.format]));
  }
  if (las.header_size < kMinHeaderBytes || las.header_size > file.size() ||
      las.offset < las.header_size || las.offset > file.size()) {
    return absl::InvalidArgumentError(absl::StrCat(name, ": header of ", las.header_size,
                                                   " bytes with points at offset ", las.offset,
                                                   " does not fit a ", file.size(), "-byte file"));
  }
  las.count = Load<uint32_t>(h + 107);
  if (las.minor >= 4 && las.header_size >= kHeader14Bytes) las.count = Load<uint64_t>(h + 247);
  const uint64_t end = PointDataEnd(file, las.minor, las.header_size, las.offset);
  const uint64_t room = (end - las.offset) / las.record;
  if (las.count > room) {
    return absl::InvalidArgumentError(absl::StrCat(name, ": header claims ", las.count,
                                                   " points of ", las.record, " bytes from offset ",
                                                   las.offset, "; the file holds ", room));
  }
  // Records the header does not count would be left out unseen: refused as PLY and PCD refuse a
  // body longer than their counts.
  if (las.count * las.record != end - las.offset) {
    return absl::InvalidArgumentError(absl::StrCat(
        name, ": header claims ", las.count, " points of ", las.record, " bytes from offset ",
        las.offset, " but the point data holds ", end - las.offset, " bytes (", room,
        " points): wrong count (counts disagree)"));
  }
  // Integer coordinates are always a measurement; an empty file fails as in every reader.
  if (las.count == 0) return NoPointsError(name);
  SCANPREP_RETURN_IF_ERROR(ReadGrid(h, name, las));
  return las;
}

// Splits the records into scanlines by their bit 6 (scan direction) and bit 7 (edge of flight
// line, the last point of its line).
class FlightLines {
 public:
  // The scanline of record `i`, whose two flag bits are `flags`.
  uint32_t LineOf(uint64_t i, uint8_t flags) {
    // The edge flag marks a line's last point; some scanners mark its first as well, so an edge
    // point that opened its line ends nothing.
    const bool turned = ((flags ^ previous_) & 0x40) != 0;
    const bool after_last = (previous_ & 0x80) != 0 && i - 1 > line_start_;
    if (i > 0 && (turned || after_last)) {
      ++breaks_;
      line_start_ = i;
    }
    previous_ = flags;
    return breaks_;
  }

  uint32_t breaks() const { return breaks_; }  // scanlines - 1

 private:
  uint32_t breaks_ = 0;
  uint8_t previous_ = 0;
  uint64_t line_start_ = 0;
};

// The range of the records' scan angles, degrees.
struct AngleRange {
  double min = std::numeric_limits<double>::infinity(), max = -min;
};

// Where a point data format keeps its red, green, blue (uint16 each) and its GPS time (float64);
// 0 = it has none.
constexpr uint16_t kRgbOffset[] = {0, 0, 20, 28, 0, 28, 0, 30, 30, 0, 30};
constexpr uint16_t kGpsTimeOffset[] = {0, 20, 0, 20, 20, 20, 22, 22, 22, 22, 22};

// The records' colour as the attributes red, green, blue (uint16, as LAS stores them) and their
// GPS time as gps_time (float64), for the output: no stage reads them.
void DecodeAttributes(std::string_view file, const LasLayout& las, PointCloud& cloud) {
  const auto decode = [&](const char* name, AttributeType type, uint16_t at) {
    PointAttribute& attribute =
        cloud.attributes.emplace_back(PointAttribute{.name = name, .type = type});
    attribute.Resize(las.count);
    const char* p = file.data() + las.offset + at;
    for (uint64_t i = 0; i < las.count; ++i, p += las.record) {
      attribute.Set(i, type == AttributeType::kFloat64 ? Load<double>(p)
                                                       : static_cast<double>(Load<uint16_t>(p)));
    }
  };
  if (const uint16_t at = kRgbOffset[las.format]; at != 0) {
    decode("red", AttributeType::kUint16, at);
    decode("green", AttributeType::kUint16, at + 2);
    decode("blue", AttributeType::kUint16, at + 4);
  }
  if (const uint16_t at = kGpsTimeOffset[las.format]; at != 0) {
    decode("gps_time", AttributeType::kFloat64, at);
  }
}

// Every record's coordinates (relative to cloud.origin), intensity and scanline into `cloud`;
// returns their scan angles' range. Coordinates that a float cannot hold within half the file's
// scale are refused.
absl::StatusOr<AngleRange> DecodeRecords(std::string_view file, const LasLayout& las,
                                         const std::string& name, FlightLines& lines,
                                         PointCloud& cloud) {
  const uint64_t count = las.count;
  cloud.x.resize(count), cloud.y.resize(count), cloud.z.resize(count);
  cloud.intensity.resize(count);
  std::vector<uint32_t> line(count);
  const bool extended = las.format >= 6;  // formats 6..10 moved the flags and widened the angle
  AngleRange angles;
  for (uint64_t i = 0; i < count; ++i) {
    const char* p = file.data() + las.offset + i * las.record;
    float* xyz[3] = {&cloud.x[i], &cloud.y[i], &cloud.z[i]};
    for (int k = 0; k < 3; ++k) {
      const double v = Load<int32_t>(p + 4 * k) * las.scale[k] + las.shift[k];
      const double local = v - cloud.origin[k];
      *xyz[k] = NarrowToFloat(local);
      // Within half a unit of the file's scale, a LAS written back from it has the same integers.
      if (!(std::abs(*xyz[k] - local) <= 0.5 * std::abs(las.scale[k]))) {
        return absl::InvalidArgumentError(absl::StrFormat(
            "%s: point %d %c = %.17g is %.17g from the local origin %.17g, too far for a float "
            "to keep it within half its scale %g (the file spans more than float's 24 bits "
            "of its scale)",
            name, i, "xyz"[k], v, local, cloud.origin[k], las.scale[k]));
      }
    }
    cloud.intensity[i] = Load<uint16_t>(p + 12);
    line[i] = lines.LineOf(i, static_cast<uint8_t>(p[extended ? 15 : 14]) & 0xC0);
    const double angle = extended ? Load<int16_t>(p + 18) * 0.006 : static_cast<int8_t>(p[16]);
    angles.min = std::min(angles.min, angle), angles.max = std::max(angles.max, angle);
  }
  if (lines.breaks() > 0) cloud.scanline = std::move(line);
  return angles;
}

}  // namespace

absl::StatusOr<PointCloud> ReadLasBytes(std::string_view file, const std::string& name,
                                        std::vector<std::string>& warnings) {
  SCANPREP_ASSIGN_OR_RETURN(const LasLayout las, ReadLayout(file, name));
  PointCloud cloud;
  cloud.origin =
      RecordsOrigin(file.data() + las.offset, las.count, las.record, las.scale, las.shift);
  cloud.grid = CoordinateGrid{.scale = {las.scale[0], las.scale[1], las.scale[2]},
                              .offset = {las.shift[0], las.shift[1], las.shift[2]}};
  FlightLines lines;
  SCANPREP_ASSIGN_OR_RETURN(const AngleRange angles, DecodeRecords(file, las, name, lines, cloud));
  DecodeAttributes(file, las, cloud);
  const std::string stem = std::filesystem::path(name).stem().string();
  cloud.scans.push_back(ScanMeta{.id = stem});
  // Legal arithmetic, but no scanner measures mirrored: said, so a writer's sign slip is seen.
  for (int k = 0; k < 3; ++k) {
    if (las.scale[k] > 0) continue;
    warnings.push_back(absl::StrCat(name, ": ", std::string(1, "xyz"[k]), " scale ", las.scale[k],
                                    " is negative: its ", std::string(1, "xyz"[k]),
                                    " coordinates are read mirrored (integer times scale plus "
                                    "offset, as the header says); if the writer meant ",
                                    -las.scale[k], ", the part comes out mirrored"));
  }
  warnings.push_back(absl::StrFormat(
      "%s: LAS %d.%d, point format %d: scan angle from %.3f to %.3f degrees, %d scanlines by "
      "scan direction and flight-line edge; not kept: classification, returns, scan angle, user "
      "data, point source ID%s",
      name, las.major, las.minor, las.format, angles.min, angles.max, lines.breaks() + 1,
      las.record > kRecordBytes[las.format]
          ? absl::StrFormat(", %d extra bytes a record", las.record - kRecordBytes[las.format])
          : ""));
  warnings.push_back(absl::StrCat(name,
                                  ": LAS carries no sensor origin: give the scan's "
                                  "camera_position or view_direction in a job file"));
  cloud.FinishLoading();
  return cloud;
}

absl::StatusOr<PointCloud> ReadLas(const std::filesystem::path& path,
                                   std::vector<std::string>& warnings) {
  if (absl::AsciiStrToLower(path.extension().string()) == ".laz") return Laz(path.string());
  SCANPREP_ASSIGN_OR_RETURN(std::string bytes, ReadFileToString(path));
  return ReadLasBytes(bytes, path.string(), warnings);
}

absl::StatusOr<PointCloud> ReadLas(std::istream& in, const std::string& name_for_errors,
                                   std::vector<std::string>& warnings) {
  SCANPREP_ASSIGN_OR_RETURN(std::string bytes, ReadStreamToString(in, name_for_errors));
  return ReadLasBytes(bytes, name_for_errors, warnings);
}

}  // namespace scanprep::io
