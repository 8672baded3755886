// A small simulated sequence for tests: fewer beams and columns than the default HDL-64E-like LiDAR.
#pragma once

#include "densemap/io/lidar_simulator.h"

namespace densemap::test {

inline io::LidarSimulatorOptions smallSimulator(int scans, int rows = 32, int columns = 512,
                                                double speed = 1.0, double noise = 0.0) {
  io::LidarSimulatorOptions o;
  o.scans = scans;
  o.lidar.rows = rows;
  o.lidar.columns = columns;
  o.speed = speed;
  o.range_noise = noise;
  return o;
}

}  // namespace densemap::test
