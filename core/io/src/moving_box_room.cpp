#include "densemap/io/moving_box_room.h"

#include <cmath>
#include <stdexcept>

#include <fmt/format.h>

namespace densemap::io {

namespace {
/// Distance to the nearest box along a unit ray (slab test), if any within max_range.
std::optional<double> castRay(const std::vector<MovingBoxRoom::Box>& boxes, const Eigen::Vector3d& o,
                              const Eigen::Vector3d& d, double max_range) {
  std::optional<double> best;
  for (const auto& b : boxes) {
    double t0 = 0.0, t1 = max_range;
    bool hit = true;
    for (int a = 0; a < 3 && hit; ++a) {
      if (std::abs(d[a]) < 1e-12) {
        hit = o[a] >= b.lo[a] && o[a] <= b.hi[a];
        continue;
      }
      double ta = (b.lo[a] - o[a]) / d[a], tb = (b.hi[a] - o[a]) / d[a];
      if (ta > tb) std::swap(ta, tb);
      t0 = std::max(t0, ta);
      t1 = std::min(t1, tb);
      hit = t0 <= t1;
    }
    if (hit && t0 > 0.0 && (!best || t0 < *best)) best = t0;
  }
  return best;
}
}  // namespace

MovingBoxRoom::MovingBoxRoom(const MovingBoxRoomOptions& options) : options_(options) {
  if (options_.scans < 1 || options_.rows < 2 || options_.columns < 1 || options_.move_at < 0)
    throw std::invalid_argument("moving-box room: scans >= 1, rows >= 2, columns >= 1, move_at >= 0");
}

Scan MovingBoxRoom::read(std::size_t i) const {
  if (i >= size()) throw SourceError(fmt::format("moving-box room: scan {} of {}", i, size()));
  std::vector<Box> scene = walls_;
  scene.push_back(static_cast<int>(i) < options_.move_at ? old_place_ : new_place_);
  Scan s;
  s.index = i;
  s.frame = PointFrame::kSensor;
  s.pose = Eigen::Isometry3d::Identity();
  s.pose.translation() = sensor_;
  for (int r = 0; r < options_.rows; ++r) {
    const double el = (-20.0 + r * 40.0 / (options_.rows - 1)) * M_PI / 180.0;
    for (int c = 0; c < options_.columns; ++c) {
      const double az = c * 2.0 * M_PI / options_.columns;
      const Eigen::Vector3d d(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
      if (auto t = castRay(scene, sensor_, d, 30.0)) s.points.push_back((*t * d).cast<float>());
    }
  }
  return s;
}

std::string MovingBoxRoom::describe() const {
  return fmt::format("moving-box room, {} scans, the box moves at scan {}", options_.scans, options_.move_at);
}

}  // namespace densemap::io
