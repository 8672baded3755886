// A seeded procedural street scene for the LiDAR simulator: a ground plane, buildings along both sides of a
// road (axis-aligned boxes), parked boxes (cars), poles (vertical cylinders) and trees (cylinder trunk plus
// spherical crown). Ray casting against it is exact (closed-form intersections).
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include <Eigen/Core>

namespace densemap::io {

struct SceneOptions {
  std::uint64_t seed = 1;
  double length = 120.0;         ///< road length along x (m), centred on x = 0
  double road_half_width = 7.0;  ///< buildings start this far from the road's centre line (m)
  int buildings_per_side = 8;
  int boxes = 12;
  int poles = 16;
  int trees = 10;
};

class ProceduralScene {
 public:
  struct Box {
    Eigen::Vector3d lo, hi;
  };
  struct Cylinder {  // vertical, from z0 to z1
    Eigen::Vector2d center;
    double radius, z0, z1;
  };
  struct Sphere {
    Eigen::Vector3d center;
    double radius;
  };

  explicit ProceduralScene(const SceneOptions& options = {});

  /// Distance along the unit direction `dir` from `origin` to the first surface, if within max_range.
  std::optional<double> cast(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir,
                             double max_range) const;

  const std::vector<Box>& boxes() const { return boxes_; }
  const std::vector<Cylinder>& cylinders() const { return cylinders_; }
  const std::vector<Sphere>& spheres() const { return spheres_; }
  const SceneOptions& options() const { return options_; }

 private:
  SceneOptions options_;
  std::vector<Box> boxes_;
  std::vector<Cylinder> cylinders_;
  std::vector<Sphere> spheres_;
};

}  // namespace densemap::io
