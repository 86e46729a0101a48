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

}  // namespace

absl::StatusOr<PointCloud> ReadLasBytes(std::string_view file, const std::string& name,
                                        std::vector<std::string>& warnings) {
  if (file.size() < kMinHeaderBytes || file.substr(0, 4) != "LASF") {
    return absl::InvalidArgumentError(absl::StrCat(name, ": not a LAS file (no 'LASF' signature)"));
  }
  const char* h = file.data();
  const int major = static_cast<uint8_t>(h[24]), minor = static_cast<uint8_t>(h[25]);
  const uint16_t header_size = Load<uint16_t>(h + 94);
  const uint32_t offset = Load<uint32_t>(h + 96);
  const uint8_t format_id = static_cast<uint8_t>(h[104]);
  const uint16_t record = Load<uint16_t>(h + 105);
  if (major != 1 || minor > 4) {
    return absl::InvalidArgumentError(
        absl::StrCat(name, ": LAS version ", major, ".", minor, " (this reader knows 1.0 to 1.4)"));
  }
  if ((format_id & 0xC0) != 0) return Laz(name);
  const int format = format_id;
  if (format > 10) {
    return absl::InvalidArgumentError(
        absl::StrCat(name, ": point data format ", format, " (LAS defines 0 to 10)"));
  }
  if (record < kRecordBytes[format]) {
    return absl::InvalidArgumentError(absl::StrCat(name, ": point records of ", record,
                                                   " bytes, format ", format, " needs at least ",
                                                   kRecordBytes[format]));
  }
  if (header_size < kMinHeaderBytes || header_size > file.size() || offset < header_size ||
      offset > file.size()) {
    return absl::InvalidArgumentError(absl::StrCat(name, ": header of ", header_size,
                                                   " bytes with points at offset ", offset,
                                                   " does not fit a ", file.size(), "-byte file"));
  }
  uint64_t count = Load<uint32_t>(h + 107);
  if (minor >= 4 && header_size >= kHeader14Bytes) count = Load<uint64_t>(h + 247);
  const uint64_t end = PointDataEnd(file, minor, header_size, offset);
  const uint64_t room = (end - offset) / record;
  if (count > room) {
    return absl::InvalidArgumentError(absl::StrCat(name, ": header claims ", count, " points of ",
                                                   record, " bytes from offset ", offset,
                                                   "; the file holds ", room));
  }
  // Records the header does not count would be left out unseen: refused as PLY and PCD refuse a
  // body longer than their counts.
  if (count * record != end - offset) {
    return absl::InvalidArgumentError(
        absl::StrCat(name, ": header claims ", count, " points of ", record, " bytes from offset ",
                     offset, " but the point data holds ", end - offset, " bytes (", room,
                     " points): wrong count (counts disagree)"));
  }
  // Integer coordinates are always a measurement; an empty file fails as in every reader.
  if (count == 0) return NoPointsError(name);
  double scale[3], shift[3];
  for (int k = 0; k < 3; ++k) {
    scale[k] = Load<double>(h + 131 + 8 * k);
    shift[k] = Load<double>(h + 155 + 8 * k);
    if (!std::isfinite(scale[k]) || scale[k] == 0 || !std::isfinite(shift[k])) {
      return absl::InvalidArgumentError(absl::StrCat(name, ": ", std::string(1, "xyz"[k]),
                                                     " scale ", scale[k], " and offset ", shift[k],
                                                     " (a scale must be finite and non-zero)"));
    }
  }

  PointCloud cloud;
  cloud.origin = RecordsOrigin(h + offset, count, record, scale, shift);
  cloud.grid = CoordinateGrid{.scale = {scale[0], scale[1], scale[2]},
                              .offset = {shift[0], shift[1], shift[2]}};
  cloud.x.resize(count), cloud.y.resize(count), cloud.z.resize(count);
  cloud.intensity.resize(count);
  std::vector<uint32_t> line(count);
  const bool extended = format >= 6;  // formats 6..10 moved the flags and widened the angle
  double angle_min = std::numeric_limits<double>::infinity(), angle_max = -angle_min;
  uint32_t lines = 0;
  uint8_t previous = 0;
  uint64_t line_start = 0;
  for (uint64_t i = 0; i < count; ++i) {
    const char* p = h + offset + i * record;
    float* xyz[3] = {&cloud.x[i], &cloud.y[i], &cloud.z[i]};
    for (int k = 0; k < 3; ++k) {
      const double v = Load<int32_t>(p + 4 * k) * scale[k] + shift[k];
      const double local = v - cloud.origin[k];
      *xyz[k] = NarrowToFloat(local);
      // Within half a unit of the file's scale, a LAS written back from it has the same integers.
      if (!(std::abs(*xyz[k] - local) <= 0.5 * std::abs(scale[k]))) {
        return absl::InvalidArgumentError(absl::StrFormat(
            "%s: point %d %c = %.17g is %.17g from the local origin %.17g, too far for a float "
            "to keep it within half its scale %g (the file spans more than float's 24 bits "
            "of its scale)",
            name, i, "xyz"[k], v, local, cloud.origin[k], scale[k]));
      }
    }
    cloud.intensity[i] = Load<uint16_t>(p + 12);
    // Bit 6: scan direction, bit 7: edge of flight line (the last point of its line).
    const uint8_t flags = static_cast<uint8_t>(p[extended ? 15 : 14]) & 0xC0;
    // The edge flag marks a line's last point; some scanners mark its first as well, so an edge
    // point that opened its line ends nothing.
    const bool turned = ((flags ^ previous) & 0x40) != 0;
    const bool after_last = (previous & 0x80) != 0 && i - 1 > line_start;
    if (i > 0 && (turned || after_last)) {
      ++lines;
      line_start = i;
    }
    line[i] = lines;
    previous = flags;
    const double angle = extended ? Load<int16_t>(p + 18) * 0.006 : static_cast<int8_t>(p[16]);
    angle_min = std::min(angle_min, angle), angle_max = std::max(angle_max, angle);
  }
  if (lines > 0) cloud.scanline = std::move(line);
  const std::string stem = std::filesystem::path(name).stem().string();
  cloud.scans.push_back(ScanMeta{.id = stem});
  warnings.push_back(
      absl::StrFormat("%s: LAS %d.%d, point format %d: scan angle from %.3f to %.3f "
                      "degrees, %d scanlines by scan direction and flight-line edge",
                      name, major, minor, format, angle_min, angle_max, lines + 1));
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
