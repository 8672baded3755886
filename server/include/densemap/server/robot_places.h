// Where each robot last was, for the map window: blocks far from every robot leave memory. A
// robot silent past the timeout (map time: the scans' receive time) is forgotten, so a robot that stopped
// sending does not hold its neighbourhood in memory forever. Used by the exact map's window and by the
// dense layer's, each on its own writer thread.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "densemap/geometry/voxel_key.h"

namespace densemap::server {

class RobotPlaces {
 public:
  /// `timeout_s` 0: robots are never forgotten.
  explicit RobotPlaces(double timeout_s) : timeout_s_(timeout_s) {}

  /// `robot` was at `position` at map time `now_s`. Returns the robots forgotten now, with how long each
  /// had been silent.
  std::vector<std::pair<std::string, double>> update(const std::string& robot,
                                                     const geometry::Vec3f& position, double now_s);
  /// A robot known from a snapshot (its time is not kept there): its clock starts at the next update.
  void restore(const std::string& robot, const geometry::Vec3f& position);
  std::vector<geometry::Vec3f> positions() const;
  const std::map<std::string, geometry::Vec3f>& byRobot() const { return positions_; }
  void clear();

 private:
  double timeout_s_;
  std::map<std::string, geometry::Vec3f> positions_;
  std::map<std::string, double> last_s_;  // NaN: restored, not heard from since
};

}  // namespace densemap::server
