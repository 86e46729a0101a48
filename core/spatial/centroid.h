// SPDX-License-Identifier: Apache-2.0
// Where a set of points lies and how far it reaches: the frame a rigid motion's rotation is
// written about (its centre) and scaled by (its RMS extent), for a pair's overlap and for a job.
#pragma once

#include <cmath>
#include <cstddef>

#include <Eigen/Core>

#include "absl/status/statusor.h"
#include "core/base/cancel.h"
#include "core/base/parallel.h"
#include "core/base/status_macros.h"

namespace scanprep {

struct Centroid {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  double rms_extent = 0;  // √(mean |p − centre|²)
};

// Of the n points point(0) … point(n − 1) (each an Eigen::Vector3d, in double), in parallel, in
// fixed blocks (the same on any number of threads); zero for none.
template <typename Point>
absl::StatusOr<Centroid> CentroidOf(size_t n, Point point, const CancelToken& cancel) {
  Centroid c;
  if (n == 0) return c;
  SCANPREP_RETURN_IF_ERROR(ParallelSum(
      n, cancel, Eigen::Vector3d::Zero().eval(),
      [&](size_t begin, size_t end) -> Eigen::Vector3d {
        Eigen::Vector3d part = Eigen::Vector3d::Zero();
        for (size_t i = begin; i < end; ++i) part += point(i);
        return part;
      },
      c.centre));
  c.centre /= double(n);
  double squared = 0;
  SCANPREP_RETURN_IF_ERROR(ParallelSum(
      n, cancel, 0.0,
      [&](size_t begin, size_t end) {
        double part = 0;
        for (size_t i = begin; i < end; ++i) part += (point(i) - c.centre).squaredNorm();
        return part;
      },
      squared));
  c.rms_extent = std::sqrt(squared / double(n));
  return c;
}

}  // namespace scanprep
