// SPDX-License-Identifier: Apache-2.0
#include "core/io/local_frame.h"

#include <cmath>
#include <limits>

#include "absl/strings/str_cat.h"
#include "core/base/free_memory.h"
#include "core/io/float_narrowing.h"

namespace scanprep::io {

Eigen::Vector3d LocalOrigin(const Eigen::Vector3d& min, const Eigen::Vector3d& max) {
  const Eigen::Vector3d centre = 0.5 * min + 0.5 * max;
  const double extent = (max - min).maxCoeff();
  if (!std::isfinite(extent) || !centre.allFinite()) return Eigen::Vector3d::Zero();
  // Within 16 extents of zero float loses at most 5 of its 24 bits to the offset.
  if (centre.cwiseAbs().maxCoeff() <= 16 * extent) return Eigen::Vector3d::Zero();
  if (extent == 0) return centre;  // one position: every local coordinate is 0
  const double step = std::pow(10.0, std::floor(std::log10(extent)));
  Eigen::Vector3d origin;
  for (int k = 0; k < 3; ++k) origin[k] = std::round(centre[k] / step) * step;
  return origin;
}

absl::Status WideCoordinates::Narrow(PointCloud& cloud, const std::string& name) {
  const size_t n = x_.size();
  constexpr double kInf = std::numeric_limits<double>::infinity();
  Eigen::Vector3d min(kInf, kInf, kInf), max = -min;
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d p(x_[i], y_[i], z_[i]);
    if (!p.allFinite()) continue;
    min = min.cwiseMin(p), max = max.cwiseMax(p);
  }
  cloud.origin = n > 0 && min.allFinite() ? LocalOrigin(min, max) : Eigen::Vector3d::Zero();
  std::vector<double>* wide[3] = {&x_, &y_, &z_};
  std::vector<float>* narrow[3] = {&cloud.x, &cloud.y, &cloud.z};
  for (int k = 0; k < 3; ++k) {
    narrow[k]->resize(n);
    for (size_t i = 0; i < n; ++i) {
      const double v = (*wide[k])[i];
      const float local = NarrowToFloat(v - cloud.origin[k]);
      if (std::isfinite(v) && !std::isfinite(local)) {
        return absl::InvalidArgumentError(absl::StrCat(name, ": point ", i, " ",
                                                       std::string(1, "xyz"[k]), " = ", v,
                                                       " is beyond the range of a float"));
      }
      (*narrow[k])[i] = local;
    }
    FreeMemory(*wide[k]);
  }
  return absl::OkStatus();
}

}  // namespace scanprep::io
