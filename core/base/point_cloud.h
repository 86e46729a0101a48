// SPDX-License-Identifier: Apache-2.0
// Structure-of-arrays point cloud: the one data type every stage reads and writes.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/base/point_attributes.h"

namespace scanprep {

// Per-point flag bits. A removed point stays in the arrays (removal is by label, paper §3.3)
// until the output stage decides whether to return it.
enum PointFlag : uint8_t {
  kRemovedOutlier = 1u << 0,
  kRemovedMerge = 1u << 1,
  kRemovedSimplify = 1u << 2,
  kSmoothed = 1u << 3,       // the smoothing stage moved the point
  kNormalInvalid = 1u << 4,  // fewer than 3 neighbours or a collinear neighbourhood
  kEdge = 1u << 5,           // normalised curvature at or above the edge threshold
};
constexpr uint8_t kRemovedMask = kRemovedOutlier | kRemovedMerge | kRemovedSimplify;

enum class ScannerKind { kLine, kFlexible };

// What the scanner knows about one scan, already in the common frame and in millimetres.
struct ScanMeta {
  std::string id;
  // The physical sensor that took the scan (ScanHeader.sensor_id); empty = not stated. Several
  // scans of a job may share one. Health is reported and exported per sensor.
  std::string sensor_id;
  std::optional<Eigen::Vector3d> camera_position;
  // Sweeping line scanners have no single camera centre: the unit direction from the surface
  // toward the camera, constant over the scan.
  std::optional<Eigen::Vector3d> view_direction;
  std::optional<Eigen::Vector3d> projector_position;
  std::optional<Eigen::Vector3d> projector_direction;
  double scanline_spacing = 0.0;  // Δs; 0 when the sensor has no fixed spacing
  double uncertainty = 0.1;       // u
  // False when the job stated no u and the 0.1 mm default above stands in for it (the stages
  // that use u then say so in the report).
  bool uncertainty_stated = true;
  double point_spacing = 0.0;  // nominal spacing along a scanline; 0 = derive from data
  // The scan's points that had no position (NaN, infinite or out of range) and are not in the
  // cloud: left out by a file reader (ScanHeader.points_unmeasured on the wire) or by the server.
  // Health reports them as the scan's invalid share.
  uint64_t points_invalid = 0;
};

// The grid a file stored its coordinates on as integers, per axis: value = integer * scale +
// offset, in the file's unit (LAS). Kept with what is read from such a file so that a LAS written
// back puts every point nothing moved on its own integer again.
struct CoordinateGrid {
  Eigen::Vector3d scale, offset;
};

struct PointCloud {
  // Coordinates in millimetres in the common frame, relative to `origin`: float carries about
  // seven digits, so a scan far from the frame's zero (a georeferenced LAS, a plant grid) is held
  // near its own origin and only the files and the wire see origin + (x, y, z), in double.
  std::vector<float> x, y, z;
  // Where the local zero of (x, y, z) lies in the frame, in the same unit; zero for a cloud near
  // the frame's zero. The stages never read it: every length they use is a difference.
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  // The grid of the file the points came from, when it had one (LAS); only the writers read it.
  std::optional<CoordinateGrid> grid;
  // Index into `scans`; all zero for a single scan.
  std::vector<uint32_t> scan;
  // Scanline index within the scan; empty when the scanner has no scanlines. Points of one
  // scanline appear in the arrays in their order along the line.
  std::vector<uint32_t> scanline;
  // Optional scanner-delivered quality in [0,1] (1 = trustworthy); empty when absent.
  std::vector<float> quality;
  // Optional intensity, carried through untouched; empty when absent.
  std::vector<float> intensity;
  // A file's other per-point fields (colour, a scanner's scalars), each one value per point: kept
  // by the readers and writers, never sent to the service (the client joins them back).
  std::vector<PointAttribute> attributes;
  // Unit normals; empty until a stage estimates them.
  std::vector<float> nx, ny, nz;
  std::vector<uint8_t> flags;

  std::vector<ScanMeta> scans;
  ScannerKind kind = ScannerKind::kLine;

  size_t size() const { return x.size(); }
  bool has_scanlines() const { return !scanline.empty(); }
  bool has_normals() const { return !nx.empty(); }
  bool removed(size_t i) const { return (flags[i] & kRemovedMask) != 0; }
  size_t CountKept() const;

  Eigen::Vector3f point(size_t i) const { return {x[i], y[i], z[i]}; }
  Eigen::Vector3f normal(size_t i) const { return {nx[i], ny[i], nz[i]}; }
  // ‖p_i − p_j‖² summed as (dx² + dy²) + dz² in float, the way CellGrid and nanoflann sum it,
  // so a ball answered from the k-NN lists holds exactly the points the grid's would.
  float squared_distance(size_t i, size_t j) const {
    const float dx = x[i] - x[j], dy = y[i] - y[j], dz = z[i] - z[j];
    return dx * dx + dy * dy + dz * dz;
  }

  // Sets `flags` to `loaded` (a file's flags, one per point, as scanprep writes them) or, when
  // that is empty, to zeros, and `scan` to all-zero when a loader left it empty; call once after
  // loading.
  void FinishLoading(std::vector<uint8_t> loaded = {});
};

}  // namespace scanprep
