// SPDX-License-Identifier: Apache-2.0
// Analytic parts scanned by a simulated laser-line triangulation sensor, with ground truth
// for every sample (true surface point, true outward normal, spike label, distance to the
// nearest sharp edge). Everything is in millimetres and deterministic for a seed.
//
// Used by the tests as ground truth, by the benchmarks, and by `scanprep simulate` / `scanprep
// load --simulate` to generate realistic scans when no real data is at hand.
//
// Sensor model (why it looks like this: it must produce what a light-section scanner delivers):
// - The laser is a collimated sheet travelling along -d_l, d_l = unit(laser_position − part
//   centre). It is swept along w = d_l × u (u = the line direction inside the sheet), so the
//   scanlines are parallel laser planes `scanline_spacing` apart, sampled every `point_spacing`
//   along u. Each laser ray is cast to the first surface it meets.
// - The camera is a pinhole at camera_position (fixed during the sweep). A sample is kept only if
//   the surface faces both the laser and the camera, the camera sees it unoccluded and the worse
//   of the two angles q = max(α, β) is below 80° (real sensors lose the line at grazing angles).
// - Range noise is along the camera ray with std noise_sigma / cos(q); spikes are samples
//   displaced along the camera ray by ±[outlier_min_sigma, 20]·that std.
// - ScanMeta: camera_position, projector_direction = d_l (from the surface toward the laser; a
//   collimated sheet has no origin), scanline_spacing, point_spacing, uncertainty u = 3·σ.
//   The misregistration moves the scan's points and its camera position rigidly.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/base/point_cloud.h"

namespace scanprep::sim {

// Analytic parts with known surfaces, in millimetres.
enum class Part { kPlane, kSphere, kCylinder, kBoxWithBore, kSteppedBlock };

struct PartGeometry {
  // kPlane: z = 0, |x|, |y| <= plane_half; outward normal +z.
  static constexpr double plane_half = 10.0;
  // kSphere: centred at the origin.
  static constexpr double sphere_radius = 10.0;
  // kCylinder: open tube, axis along y, |y| <= cylinder_half_length.
  static constexpr double cylinder_radius = 10.0;
  static constexpr double cylinder_half_length = 10.0;
  // kBoxWithBore: [-box_half_x, box_half_x] × [-box_half_y, box_half_y] × [0, box_height], with a
  // cylindrical bore of radius bore_radius along z through its centre. All 90° edges are sharp.
  static constexpr double box_half_x = 12.0;
  static constexpr double box_half_y = 8.0;
  static constexpr double box_height = 8.0;
  static constexpr double bore_radius = 3.0;
  // kSteppedBlock: the same box with a slot |x| < slot_half_width, slot_depth deep, milled along
  // y through its top, and a bore of radius stepped_bore_radius along z at x = stepped_bore_x,
  // y = 0 (in the shoulder right of the slot). The slot's and the bore's rims are convex edges,
  // the lines where the slot's walls meet its floor concave ones (stepped_block.h).
  static constexpr double slot_half_width = 3.0;
  static constexpr double slot_depth = 3.0;
  static constexpr double stepped_bore_x = 7.5;
  static constexpr double stepped_bore_radius = 2.0;
};

// A laser-line sensor sweeping along a direction: scanlines are parallel laser planes spaced
// `scanline_spacing` apart; points along each line `point_spacing` apart; the camera sits at an
// offset from the laser (triangulation).
struct SimSensor {
  Eigen::Vector3d camera_position;  // camera centre (mm)
  Eigen::Vector3d laser_position;   // where the laser sheet comes from (sets its direction)
  double scanline_spacing = 0.2;    // Δs
  double point_spacing = 0.1;       // along a line
  double noise_sigma = 0.01;        // std of range noise at frontal view; grows like 1/cos(q)
  double outlier_fraction = 0.0;    // spikes displaced along the viewing ray
  double outlier_min_sigma = 5.0;   // spike displacement >= this many (local) sigma, up to 20
  Eigen::Isometry3d misregistration = Eigen::Isometry3d::Identity();  // applied to this scan
  std::string id;
};

struct SimulatedCloud {
  PointCloud cloud;                          // kind kLine, one ScanMeta per sensor
  std::vector<Eigen::Vector3f> truth;        // noise-free surface point each sample came from
  std::vector<Eigen::Vector3f> true_normal;  // outward unit normal of the true surface there
  std::vector<uint8_t> is_outlier;           // 1 for injected spikes
  std::vector<float> edge_distance;          // distance of the true point to the nearest sharp
                                             // edge (infinity if the part has none)
  std::vector<uint8_t> edge_convex;          // 1 when that nearest edge is convex (or there is
                                             // none), 0 when it is concave
};

SimulatedCloud Simulate(Part part, const std::vector<SimSensor>& sensors, uint64_t seed);

// Unsigned distance from p to the part's true surface, and the outward normal of the closest
// surface point.
double DistanceToSurface(Part part, const Eigen::Vector3d& p);
Eigen::Vector3d SurfaceNormal(Part part, const Eigen::Vector3d& p);

// One sensor placed to see the part well: laser and camera 25° apart. For the box it looks
// obliquely so the top and two side faces (and their shared sharp edges) are all visible.
std::vector<SimSensor> FrontalSensor(Part part);
// Two overlapping sensors of different quality: the frontal one and an oblique (≈50°) one with
// twice the noise and a 0.02 mm misregistration (translation) — the merge stage's fixture.
std::vector<SimSensor> TwoOverlappingSensors(Part part);
// Three laser-line sensors with σ = 0.01 mm, overlapping on the top: two tilted ≈31° to +x and
// to −x (each sees the slot wall facing it and the concave edge at that wall's foot) and one
// tilted ≈31° to −y. No misregistration: the evaluation's fixture (tests/support/metrology.h).
std::vector<SimSensor> ThreeOverlappingSensors(Part part);
// Six sensors from ±x, ±y, ±z: a closed part scanned all around (for orientation without poses).
std::vector<SimSensor> SurroundingSensors(Part part);

// Simulates `sensors` with both spacings of every sensor scaled so the cloud has about `points`
// points (within 2 %), each sensor with `spike_fraction` spikes. For benchmarks and generated
// demo or load-test scans of a given size.
SimulatedCloud SimulateWithPointCount(Part part, std::vector<SimSensor> sensors, size_t points,
                                      double spike_fraction, uint64_t seed);

}  // namespace scanprep::sim
