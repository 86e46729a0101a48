// SPDX-License-Identifier: Apache-2.0
// LAS 1.2 writer, point data format 0 to 3 by the attributes it keeps: a first pass puts every
// written point on the grid and checks that LAS can hold it (the header needs the count and bounds
// before the records), a second writes the records.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>

#include "absl/strings/str_format.h"
#include "core/base/status_macros.h"
#include "core/io/byte_order.h"
#include "core/io/cloud_writer.h"
#include "core/io/las.h"

namespace scanprep::io {
namespace {

constexpr size_t kHeaderBytes = 227;  // LAS 1.2's public header; no variable-length records follow
constexpr size_t kBaseBytes = 20;     // point data format 0; GPS time adds 8, colour 6
constexpr uint8_t kNoiseClass = 7;    // ASPRS "low point (noise)": what a removed point is

// The attributes a record carries beyond format 0's fields, null where the cloud has none.
struct Extras {
  const PointAttribute* gps_time = nullptr;
  std::array<const PointAttribute*, 3> rgb{};  // all three or none
  double rgb_scale = 1;                        // 256 for 8-bit channels, as LAS 1.2 asks

  uint8_t format() const { return (gps_time ? 1 : 0) + (rgb[0] ? 2 : 0); }
  size_t record_bytes() const { return kBaseBytes + (gps_time ? 8 : 0) + (rgb[0] ? 6 : 0); }
};

const PointAttribute* Named(const std::vector<PointAttribute>& attributes, std::string_view name) {
  for (const PointAttribute& a : attributes) {
    if (a.name == name) return &a;
  }
  return nullptr;
}

// Colour LAS can hold: integer channels of at most 16 bits, unsigned or signed.
bool IsChannel(const PointAttribute* a) {
  return a != nullptr && IsIntegerAttribute(a->type) && AttributeBytes(a->type) <= 2;
}

Extras ExtrasOf(const std::vector<PointAttribute>& attributes) {
  Extras extras;
  if (const PointAttribute* t = Named(attributes, "gps_time");
      t != nullptr && !IsIntegerAttribute(t->type)) {
    extras.gps_time = t;
  }
  const std::array<const PointAttribute*, 3> rgb = {
      Named(attributes, "red"), Named(attributes, "green"), Named(attributes, "blue")};
  if (std::all_of(rgb.begin(), rgb.end(), IsChannel)) {
    extras.rgb = rgb;
    const bool eight_bits = std::all_of(rgb.begin(), rgb.end(), [](const PointAttribute* a) {
      return AttributeBytes(a->type) == 1;
    });
    extras.rgb_scale = eight_bits ? 256 : 1;
  }
  return extras;
}

template <class T>
void Store(char* at, T value) {
  if constexpr (kHostIsBigEndian) value = ByteSwapped(value);
  std::memcpy(at, &value, sizeof(T));
}

// A cloud read from a LAS keeps that file's grid; any other gets 1/1000 of its unit around its
// origin, which LocalOrigin made round already, rounded to a whole unit for a readable header.
CoordinateGrid GridOf(const PointCloud& cloud) {
  if (cloud.grid) return *cloud.grid;
  return {.scale = Eigen::Vector3d::Constant(0.001), .offset = cloud.origin.array().round()};
}

// Point i's coordinate on `axis` in steps of the grid's scale from its offset, to the nearest step.
// The origin and the offset are subtracted first: both are far from zero for a georeferenced
// cloud, the local float is not.
double Steps(const PointCloud& cloud, const CoordinateGrid& grid, size_t i, int axis) {
  const float local = axis == 0 ? cloud.x[i] : axis == 1 ? cloud.y[i] : cloud.z[i];
  return std::round(((cloud.origin[axis] - grid.offset[axis]) + local) / grid.scale[axis]);
}

struct Extent {
  size_t count = 0;
  std::array<int32_t, 3> lo{}, hi{};
};

// The written points' count and integer bounds; INVALID_ARGUMENT naming the first point LAS format
// 0 cannot hold (a coordinate beyond 32 bits of the grid, an intensity that is no 16-bit integer,
// a scan index beyond the 16-bit point source ID).
absl::StatusOr<Extent> Measure(const PointCloud& cloud, const CoordinateGrid& grid,
                               const Extras& extras, const WriteOptions& options) {
  constexpr double kMin = std::numeric_limits<int32_t>::min();
  constexpr double kMax = std::numeric_limits<int32_t>::max();
  Extent extent;
  for (size_t i = 0; i < cloud.size(); ++i) {
    if (!Written(cloud, i, options)) continue;
    for (int k = 0; k < 3; ++k) {
      const double steps = Steps(cloud, grid, i, k);
      if (!(steps >= kMin && steps <= kMax)) {
        return absl::InvalidArgumentError(absl::StrFormat(
            "cannot write LAS: point %d %c = %.17g is %.17g steps of its scale %g from its offset "
            "%.17g, beyond a 32-bit integer (PLY and PCD keep any double)",
            i, "xyz"[k], WorldPoint(cloud, i)[k], steps, grid.scale[k], grid.offset[k]));
      }
      const auto v = static_cast<int32_t>(steps);
      extent.lo[k] = extent.count == 0 ? v : std::min(extent.lo[k], v);
      extent.hi[k] = extent.count == 0 ? v : std::max(extent.hi[k], v);
    }
    if (!cloud.intensity.empty()) {
      const float value = cloud.intensity[i];
      if (!(value >= 0 && value <= 65535 && value == std::round(value))) {
        return absl::InvalidArgumentError(absl::StrFormat(
            "cannot write LAS: point %d intensity %g is not an integer from 0 to 65535 (PLY and "
            "PCD keep any intensity)",
            i, value));
      }
    }
    for (const PointAttribute* channel : extras.rgb) {
      if (channel == nullptr) continue;
      const double value = channel->Value(i) * extras.rgb_scale;
      if (!(value >= 0 && value <= 65535)) {
        return absl::InvalidArgumentError(absl::StrFormat(
            "cannot write LAS: point %d %s %g is not a colour from 0 to 65535 (PLY and PCD keep "
            "any value)",
            i, channel->name, channel->Value(i)));
      }
    }
    if (!cloud.scan.empty() && cloud.scan[i] > 65535) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "cannot write LAS: point %d of scan %d: the point source ID holds scans 0 to 65535", i,
          cloud.scan[i]));
    }
    ++extent.count;
  }
  if (extent.count > std::numeric_limits<uint32_t>::max()) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "cannot write LAS: %d points, LAS 1.2 counts at most 4294967295", extent.count));
  }
  return extent;
}

std::string Header(const CoordinateGrid& grid, const Extent& extent, const Extras& extras) {
  std::string h(kHeaderBytes, '\0');
  std::memcpy(h.data(), "LASF", 4);
  h[24] = 1, h[25] = 2;  // version 1.2
  constexpr char kName[] = "scanprep";
  std::memcpy(h.data() + 26, kName, sizeof kName - 1);  // system identifier
  std::memcpy(h.data() + 58, kName, sizeof kName - 1);  // generating software
  Store<uint16_t>(h.data() + 94, kHeaderBytes);
  Store<uint32_t>(h.data() + 96, kHeaderBytes);  // the points follow the header
  h[104] = static_cast<char>(extras.format());
  Store<uint16_t>(h.data() + 105, static_cast<uint16_t>(extras.record_bytes()));
  const auto count = static_cast<uint32_t>(extent.count);
  Store<uint32_t>(h.data() + 107, count);
  Store<uint32_t>(h.data() + 111, count);  // every point is return 1 of 1
  for (int k = 0; k < 3; ++k) {
    Store<double>(h.data() + 131 + 8 * k, grid.scale[k]);
    Store<double>(h.data() + 155 + 8 * k, grid.offset[k]);
    const double a = extent.lo[k] * grid.scale[k] + grid.offset[k];
    const double b = extent.hi[k] * grid.scale[k] + grid.offset[k];
    Store<double>(h.data() + 179 + 16 * k, std::max(a, b));  // a scale may be negative
    Store<double>(h.data() + 187 + 16 * k, std::min(a, b));
  }
  return h;
}

// Point i's record but its scan direction flag (byte 14), which follows the scanlines.
void WriteRecord(const PointCloud& cloud, const CoordinateGrid& grid, const Extras& extras,
                 size_t i, char* record) {
  std::memset(record, 0, extras.record_bytes());
  for (int k = 0; k < 3; ++k) {
    Store<int32_t>(record + 4 * k, static_cast<int32_t>(Steps(cloud, grid, i, k)));
  }
  if (!cloud.intensity.empty()) Store(record + 12, static_cast<uint16_t>(cloud.intensity[i]));
  const uint8_t flags = cloud.flags.empty() ? 0 : cloud.flags[i];
  record[15] = static_cast<char>((flags & kRemovedMask) != 0 ? kNoiseClass : 0);
  record[17] = static_cast<char>(flags);  // user data: scanprep's flags as the other writers
  Store<uint16_t>(record + 18, static_cast<uint16_t>(cloud.scan.empty() ? 0 : cloud.scan[i]));
  char* next = record + kBaseBytes;
  if (extras.gps_time != nullptr) Store<double>(next, extras.gps_time->Value(i)), next += 8;
  for (int c = 0; c < 3 && extras.rgb[0] != nullptr; ++c) {
    Store(next + 2 * c, static_cast<uint16_t>(extras.rgb[c]->Value(i) * extras.rgb_scale));
  }
}

}  // namespace

std::vector<std::string> LasKeeps(const std::vector<PointAttribute>& attributes) {
  const Extras extras = ExtrasOf(attributes);
  std::vector<std::string> kept;
  for (const PointAttribute* channel : extras.rgb) {
    if (channel != nullptr) kept.push_back(channel->name);
  }
  if (extras.gps_time != nullptr) kept.push_back(extras.gps_time->name);
  return kept;
}

absl::Status WriteLas(std::ostream& out, const PointCloud& cloud, const WriteOptions& options) {
  SCANPREP_RETURN_IF_ERROR(CheckWritable(cloud, "LAS"));
  const CoordinateGrid grid = GridOf(cloud);
  const Extras extras = ExtrasOf(cloud.attributes);
  SCANPREP_ASSIGN_OR_RETURN(const Extent extent, Measure(cloud, grid, extras, options));
  const std::string header = Header(grid, extent, extras);
  out.write(header.data(), static_cast<std::streamsize>(header.size()));

  // ReadLas starts a scanline where the scan direction flag turns, so it turns at each new line.
  bool direction = false, first = true;
  uint64_t line = 0;
  std::string record(extras.record_bytes(), '\0');
  for (size_t i = 0; i < cloud.size() && out; ++i) {
    if (!Written(cloud, i, options)) continue;
    const uint32_t scan = cloud.scan.empty() ? 0 : cloud.scan[i];
    const uint64_t this_line =
        (uint64_t{scan} << 32) | (cloud.has_scanlines() ? cloud.scanline[i] : 0);
    if (!first && this_line != line) direction = !direction;
    first = false, line = this_line;
    WriteRecord(cloud, grid, extras, i, record.data());
    record[14] = static_cast<char>(0x09 | (direction ? 0x40 : 0));  // return 1 of 1
    out.write(record.data(), static_cast<std::streamsize>(record.size()));
  }
  if (!out) return absl::UnavailableError("cannot write LAS: output stream failed");
  return absl::OkStatus();
}

absl::Status WriteLas(const std::filesystem::path& path, const PointCloud& cloud,
                      const WriteOptions& options) {
  return WriteFile(path, [&](std::ostream& out) { return WriteLas(out, cloud, options); });
}

}  // namespace scanprep::io
