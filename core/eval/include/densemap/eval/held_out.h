// The held-out protocol of Sec. 2.4.2: per scan, a seeded 80% of the points build the map and 20% are held
// out as occupied test points; one free test point is drawn uniformly along each held-out ray.
#pragma once

#include <cstdint>
#include <random>
#include <vector>

#include "densemap/geometry/voxel_key.h"

namespace densemap::eval {

using geometry::Vec3f;

struct TestPoint {
  Vec3f p;
  bool occupied;
};

struct HeldOutSplit {
  std::vector<Vec3f> map_points;  ///< what the mapping methods get
  std::vector<TestPoint> tests;   ///< held-out endpoints (occupied) and points on their rays (free)
};

struct HeldOutOptions {
  double held_out_fraction = 0.2;
  /// Free test points stay this far short of the endpoint (half a cell: not inside the occupied cell).
  double end_margin = 0.05;
  double max_range = -1.0;  ///< held-out points beyond it are not tested (rays cut there)
};

HeldOutSplit splitScan(const std::vector<Vec3f>& points, const Vec3f& origin, const HeldOutOptions& options,
                       std::mt19937_64& rng);

}  // namespace densemap::eval
