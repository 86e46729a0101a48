// SPDX-License-Identifier: Apache-2.0
// The hostile-input workloads (issue 11, docs/hostile-inputs.md): the benchmark's reference cloud
// with one thing wrong, each of about `points` points and cached per size like ReferenceCloud.
// The same cases as tools/lib/hostile_cases.py makes for the service.
#pragma once

#include <cstddef>

#include "core/base/point_cloud.h"

namespace scanprep::bench {

// One point of the first scan copied to x = 1e6 mm / 1e8 mm beside the cloud.
const PointCloud& FarPoint1e6Cloud(size_t points);
const PointCloud& FarPoint1e8Cloud(size_t points);
// Every 10th / every 2nd point moved onto its scan's first point: one location holding 10 % /
// 50 % of the points.
const PointCloud& Coincident10PctCloud(size_t points);
const PointCloud& Coincident50PctCloud(size_t points);
// A glint: every 4th / every 2nd point moved to a seeded uniform spot within u/2 of its scan's
// first point, 25 % / 50 % of the points in one ball (docs/hostile-inputs.md, issue 38).
const PointCloud& DenseSpot25PctCloud(size_t points);
const PointCloud& DenseSpot50PctCloud(size_t points);
// Every point on the x axis, the first scan's point spacing apart, in array order.
const PointCloud& LineCloud(size_t points);
// The generator's plane part, scanned by its two overlapping sensors.
const PointCloud& PlaneCloud(size_t points);
// Metre data sent as mm: points and scan metadata (positions, spacings, uncertainty) × 1e-3.
const PointCloud& MetreDataAsMmCloud(size_t points);
// Millimetre data sent as metres: the same × 1e3 (what the service makes of `--unit m`).
const PointCloud& MmDataAsMetresCloud(size_t points);
// A generated equivalent of rs1: one unorganized scan without camera, view direction or
// scanlines of a 400 mm floor with spheres on a 40 mm grid 5 mm above it.
const PointCloud& NoPoseUnorganizedCloud(size_t points);
// 1,000 scans of one point each (points of the first scan, with its metadata): alone (1,000
// points), and the whole cloud in 1,000 scans, all but its own two of one point each. 1,000 is
// the server's default max_scans_per_job.
const PointCloud& OnePointScans1000Cloud(size_t points);
const PointCloud& OrdinaryIn1000ScansCloud(size_t points);

}  // namespace scanprep::bench
