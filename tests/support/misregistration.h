// SPDX-License-Identifier: Apache-2.0
// The registration tests' misregistered jobs: three laser-line sensors over a part, the second
// and third moved by 5-100 µm and 0.005-0.1° about random axes, the truth kept beside the cloud.
#pragma once

#include <cstdint>
#include <numbers>
#include <random>
#include <vector>

#include <Eigen/Geometry>

#include "core/sim/scan_simulator.h"

namespace scanprep::testing {

// A rigid motion of `shift_mm` in a random direction and `deg` about a random axis.
inline Eigen::Isometry3d RandomMotion(std::mt19937& random, double shift_mm, double deg) {
  std::normal_distribution<double> normal;
  const Eigen::Vector3d axis(normal(random), normal(random), normal(random));
  const Eigen::Vector3d direction(normal(random), normal(random), normal(random));
  Eigen::Isometry3d m(Eigen::AngleAxisd(deg * std::numbers::pi / 180, axis.normalized()));
  m.translation() = direction.normalized() * shift_mm;
  return m;
}

// `part` seen by ThreeOverlappingSensors, about `points` points, no spikes; truth[s]: the motion
// scan s was moved by (the identity for the first).
inline sim::SimulatedCloud Misregistered(sim::Part part, uint64_t seed, size_t points,
                                         std::vector<Eigen::Isometry3d>& truth) {
  std::mt19937 random(static_cast<unsigned>(seed));
  std::uniform_real_distribution<double> shift(0.005, 0.1), deg(0.005, 0.1);
  std::vector<sim::SimSensor> sensors = sim::ThreeOverlappingSensors(part);
  truth.assign(sensors.size(), Eigen::Isometry3d::Identity());
  for (size_t s = 1; s < sensors.size(); ++s) {
    truth[s] = RandomMotion(random, shift(random), deg(random));
    sensors[s].misregistration = truth[s];
  }
  return sim::SimulateWithPointCount(part, sensors, points, 0, seed);
}

}  // namespace scanprep::testing
