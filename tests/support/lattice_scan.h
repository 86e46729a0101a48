// SPDX-License-Identifier: Apache-2.0
// The scan the far-coordinate tests place at offsets from 0 to 5e8 mm: the box with a bore seen
// by two overlapping sensors with 1 % spikes (every stage has work), its coordinates on a 2^-16
// mm (15 nm) lattice, as a scanner's are on its resolution's. Double carries 2^-23 mm at 5e8 mm,
// so a file there holds exactly the same scan; unquantised, the file itself would move points by
// up to 6e-8 mm and a threshold could flip.
#pragma once

#include <cmath>
#include <vector>

#include "core/sim/scan_simulator.h"

namespace scanprep::testing {

inline sim::SimulatedCloud LatticeBoxScans() {
  std::vector<sim::SimSensor> sensors = sim::TwoOverlappingSensors(sim::Part::kBoxWithBore);
  for (sim::SimSensor& s : sensors) s.outlier_fraction = 0.01;
  sim::SimulatedCloud scan = sim::Simulate(sim::Part::kBoxWithBore, sensors, 41);
  for (std::vector<float>* axis : {&scan.cloud.x, &scan.cloud.y, &scan.cloud.z}) {
    for (float& v : *axis) v = std::ldexp(std::round(std::ldexp(v, 16)), -16);
  }
  return scan;
}

}  // namespace scanprep::testing
