// The benchmark workload: a generated two-scan laser-line cloud of a box with a bore, with noise
// and 1 % spikes (the reference cloud), cached per size so every case times the same
// points.
#pragma once

#include <cstddef>

#include "core/point_cloud.h"

namespace scanprep::bench {

const PointCloud& ReferenceCloud(size_t points);

// Peak resident set size of this process so far, in bytes.
double PeakRssBytes();

}  // namespace scanprep::bench
