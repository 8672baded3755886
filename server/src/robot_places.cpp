#include "densemap/server/robot_places.h"

#include <cmath>
#include <limits>

namespace densemap::server {

std::vector<std::pair<std::string, double>> RobotPlaces::update(const std::string& robot,
                                                                const geometry::Vec3f& position,
                                                                double now_s) {
  positions_[robot] = position;
  last_s_[robot] = now_s;
  std::vector<std::pair<std::string, double>> forgotten;
  for (auto it = last_s_.begin(); it != last_s_.end();) {
    if (std::isnan(it->second)) it->second = now_s;  // restored: its clock starts now
    if (timeout_s_ > 0.0 && now_s - it->second > timeout_s_) {
      forgotten.emplace_back(it->first, now_s - it->second);
      positions_.erase(it->first);
      it = last_s_.erase(it);
    } else {
      ++it;
    }
  }
  return forgotten;
}

void RobotPlaces::restore(const std::string& robot, const geometry::Vec3f& position) {
  positions_[robot] = position;
  last_s_[robot] = std::numeric_limits<double>::quiet_NaN();
}

std::vector<geometry::Vec3f> RobotPlaces::positions() const {
  std::vector<geometry::Vec3f> out;
  out.reserve(positions_.size());
  for (const auto& [id, p] : positions_) out.push_back(p);
  return out;
}

void RobotPlaces::clear() {
  positions_.clear();
  last_s_.clear();
}

}  // namespace densemap::server
