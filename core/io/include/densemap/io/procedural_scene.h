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
  /// Off by default (the demo's and tests' scenes stay as they were); ILN's real-sensor training scenes
  /// turn them on: kerbs with raised pavements along both sides, and hedges in front of the buildings.
  bool pavements = false;
  int hedges = 0;
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

  /// The first surface hit and its unit normal there (facing the ray), for sensor models whose returns
  /// depend on the angle of incidence.
  struct Hit {
    double range = 0;
    Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
    bool vegetation = false;  ///< a tree crown or a hedge: porous, returns from inside it
  };
  std::optional<Hit> castHit(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir,
                             double max_range) const;

  const std::vector<Box>& boxes() const { return boxes_; }
  const std::vector<Cylinder>& cylinders() const { return cylinders_; }
  const std::vector<Sphere>& spheres() const { return spheres_; }
  const std::vector<Box>& hedges() const { return hedges_; }
  const SceneOptions& options() const { return options_; }

 private:
  SceneOptions options_;
  std::vector<Box> boxes_;
  std::vector<Cylinder> cylinders_;
  std::vector<Sphere> spheres_;
  std::vector<Box> hedges_;
};

}  // namespace densemap::io
