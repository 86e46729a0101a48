// SPDX-License-Identifier: Apache-2.0
// PCL 1.13 MovingLeastSquares as a user would call it: second-order polynomial, a fixed search
// radius, no upsampling, the output mapped back to the input by its corresponding indices.
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/search/kdtree.h>
#include <pcl/surface/mls.h>

#include <memory>

#include "tests/bench/metrology_peers.h"

namespace scanprep::bench {

PointCloud SmoothWithPclMls(const PointCloud& raw, double radius_mm, int threads) {
  auto in = std::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  in->reserve(raw.size());
  for (size_t i = 0; i < raw.size(); ++i) in->push_back({raw.x[i], raw.y[i], raw.z[i]});
  pcl::MovingLeastSquares<pcl::PointXYZ, pcl::PointXYZ> mls;
  mls.setInputCloud(in);
  mls.setSearchMethod(std::make_shared<pcl::search::KdTree<pcl::PointXYZ>>());
  mls.setPolynomialOrder(2);
  mls.setSearchRadius(radius_mm);
  mls.setComputeNormals(false);
  mls.setNumberOfThreads(threads);
  pcl::PointCloud<pcl::PointXYZ> out;
  mls.process(out);

  PointCloud smoothed = raw;
  for (uint8_t& f : smoothed.flags) f |= kRemovedSimplify;
  const auto& from = mls.getCorrespondingIndices()->indices;
  for (size_t j = 0; j < out.size(); ++j) {
    const size_t i = static_cast<size_t>(from[j]);
    smoothed.x[i] = out[j].x;
    smoothed.y[i] = out[j].y;
    smoothed.z[i] = out[j].z;
    smoothed.flags[i] &= static_cast<uint8_t>(~kRemovedSimplify);
  }
  return smoothed;
}

}  // namespace scanprep::bench
