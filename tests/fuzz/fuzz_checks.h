// SPDX-License-Identifier: Apache-2.0
// Invariants every successfully read or processed cloud must satisfy; a violation aborts so
// libFuzzer records the input.
#pragma once

#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "core/base/point_cloud.h"

namespace scanprep::fuzz {

inline void Require(bool ok, const char* what) {
  if (ok) return;
  std::fprintf(stderr, "fuzz invariant violated: %s\n", what);
  std::abort();
}

// Array lengths agree with the point count, coordinates are finite and scan indices are in range.
inline void CheckCloud(const PointCloud& cloud) {
  const size_t n = cloud.size();
  Require(cloud.y.size() == n && cloud.z.size() == n, "x, y, z have the same length");
  Require(cloud.scan.size() == n && cloud.flags.size() == n,
          "scan and flags sized by FinishLoading");
  Require(cloud.scanline.empty() || cloud.scanline.size() == n, "scanline absent or one per point");
  Require(cloud.quality.empty() || cloud.quality.size() == n, "quality absent or one per point");
  Require(cloud.intensity.empty() || cloud.intensity.size() == n,
          "intensity absent or one per point");
  Require(!cloud.has_normals() || (cloud.ny.size() == n && cloud.nz.size() == n),
          "normals absent or one per point");
  for (size_t i = 0; i < n; ++i) {
    Require(std::isfinite(cloud.x[i]) && std::isfinite(cloud.y[i]) && std::isfinite(cloud.z[i]),
            "finite coordinates");
    Require(cloud.scan[i] < cloud.scans.size(), "scan index names a scan");
    if (!cloud.quality.empty()) {
      Require(cloud.quality[i] >= 0.f && cloud.quality[i] <= 1.f, "quality in [0, 1]");
    }
  }
}

// After the pipeline: every normal a stage estimated and did not flag invalid is finite.
inline void CheckNormals(const PointCloud& cloud) {
  for (size_t i = 0; i < cloud.nx.size(); ++i) {
    if ((cloud.flags[i] & kNormalInvalid) != 0) continue;
    Require(std::isfinite(cloud.nx[i]) && std::isfinite(cloud.ny[i]) && std::isfinite(cloud.nz[i]),
            "finite normal where the normal is valid");
  }
}

}  // namespace scanprep::fuzz
