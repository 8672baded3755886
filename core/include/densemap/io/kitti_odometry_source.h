// KITTI odometry layout: velodyne/NNNNNN.bin (float32 x y z reflectance), poses.txt (3x4 camera poses,
// one line per scan), calib.txt ("Tr:" velodyne -> camera). World frame = velodyne frame of scan 0:
// T_i = Tr^-1 * P_i * Tr.
#pragma once

#include <vector>

#include "densemap/io/scan_source.h"

namespace densemap::io {

class KittiOdometrySource : public ScanSource {
 public:
  explicit KittiOdometrySource(const std::string& dir);
  std::size_t size() const override { return bins_.size(); }
  Scan read(std::size_t i) const override;
  std::string describe() const override;

  /// Reads "Tr:" (or "Tr_velo_to_cam:") from a calib.txt.
  static Eigen::Isometry3d readCalibration(const std::string& path);

 private:
  std::string dir_;
  std::vector<std::string> bins_;
  std::vector<Eigen::Isometry3d> poses_;  // world(velodyne 0) <- velodyne i
};

}  // namespace densemap::io
