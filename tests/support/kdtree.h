// SPDX-License-Identifier: Apache-2.0
// nanoflann kd-tree over the cloud's own coordinate arrays (an adaptor: no copy of the points).
#pragma once

#include <cstdint>
#include <utility>
#include <vector>

#include <nanoflann.hpp>

#include "core/base/point_cloud.h"
#include "core/spatial/cell_grid.h"  // RadiusMatches

namespace scanprep {

struct CloudAdaptor {
  const PointCloud* cloud;
  size_t kdtree_get_point_count() const { return cloud->size(); }
  float kdtree_get_pt(uint32_t i, size_t dim) const {
    return dim == 0 ? cloud->x[i] : dim == 1 ? cloud->y[i] : cloud->z[i];
  }
  template <class BBox>
  bool kdtree_get_bbox(BBox&) const {
    return false;
  }
};

using KdTreeIndex = nanoflann::KDTreeSingleIndexAdaptor<
    nanoflann::L2_Simple_Adaptor<float, CloudAdaptor, float, uint32_t>, CloudAdaptor, 3, uint32_t>;

class KdTree {
 public:
  explicit KdTree(const PointCloud& cloud)
      : adaptor_{&cloud}, index_(3, adaptor_, nanoflann::KDTreeSingleIndexAdaptorParams(12)) {}
  KdTree(const KdTree&) = delete;
  KdTree& operator=(const KdTree&) = delete;

  // The k nearest points to q (q itself included when it is a cloud point); returns the count.
  size_t Knn(const float* q, size_t k, uint32_t* idx, float* dist_sq) const {
    return index_.knnSearch(q, k, idx, dist_sq);
  }
  // All points with distance < radius, unsorted; `out` is reused to avoid per-query allocation.
  size_t Radius(const float* q, float radius, RadiusMatches& out) const {
    return index_.radiusSearch(q, radius * radius, out, nanoflann::SearchParams(32, 0.f, false));
  }

 private:
  CloudAdaptor adaptor_;
  KdTreeIndex index_;
};

}  // namespace scanprep
