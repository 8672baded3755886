// A closed room seen by a static LiDAR, with a box that moves at a given scan to a place nearer the sensor,
// where, being bigger, it hides its old place from every ray: no scan can clear the old place, which is
// what decay (map/decay.h) is for. The scene of decay's test and benchmark; exact ray casting.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "densemap/io/scan_source.h"

namespace densemap::io {

struct MovingBoxRoomOptions {
  int scans = 120;    ///< scans in the sequence
  int move_at = 20;   ///< the first scan with the box at its new place
  int rows = 24;      ///< beams, from -20 to +20 degrees
  int columns = 720;  ///< azimuths over 360 degrees
};

class MovingBoxRoom : public ScanSource {
 public:
  struct Box {
    Eigen::Vector3d lo, hi;
  };

  explicit MovingBoxRoom(const MovingBoxRoomOptions& options = {});
  std::size_t size() const override { return static_cast<std::size_t>(options_.scans); }
  /// Sensor-frame points; the pose is the sensor's fixed place.
  Scan read(std::size_t i) const override;
  std::string describe() const override;

  const Eigen::Vector3d& sensor() const { return sensor_; }
  const Box& oldPlace() const { return old_place_; }
  const Box& newPlace() const { return new_place_; }
  const std::vector<Box>& walls() const { return walls_; }

 private:
  MovingBoxRoomOptions options_;
  Eigen::Vector3d sensor_{0.0, 0.0, 1.0};
  Box old_place_{{4.5, -0.5, 0.4}, {5.5, 0.5, 1.6}};
  Box new_place_{{3.0, -1.0, 0.0}, {4.0, 1.0, 2.0}};
  std::vector<Box> walls_{{{-10.4, -10.4, 0.0}, {-10.0, 10.4, 3.0}},
                          {{10.0, -10.4, 0.0}, {10.4, 10.4, 3.0}},
                          {{-10.4, -10.4, 0.0}, {10.4, -10.0, 3.0}},
                          {{-10.4, 10.0, 0.0}, {10.4, 10.4, 3.0}}};
};

}  // namespace densemap::io
