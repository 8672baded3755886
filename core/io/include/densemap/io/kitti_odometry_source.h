// KITTI odometry layout: velodyne/NNNNNN.bin (float32 x y z reflectance), poses.txt (3x4 camera poses,
// one line per scan), calib.txt ("Tr:" velodyne -> camera). World frame = velodyne frame of scan 0:
// T_i = Tr^-1 * P_i * Tr.
#pragma once

#include <string_view>
#include <vector>

#include "densemap/io/scan_source.h"

namespace densemap::io {

class KittiOdometrySource : public ScanSource {
 public:
  /// Scan k is velodyne/<k>.bin with pose line k: the numbers must run from 0 without a gap unless
  /// options.allow_gaps, and poses.txt must have a line for every scan.
  explicit KittiOdometrySource(const std::string& dir, const SourceOptions& options = {});
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

/// The "Tr:" (or "Tr_velo_to_cam:") transform of a calib.txt's text; a rigid 3x4 or SourceError.
Eigen::Isometry3d parseKittiCalibration(std::string_view text, const std::string& name);
/// The camera poses of a poses.txt's text, one 3x4 rigid transform per line (trailing blank lines allowed).
std::vector<Eigen::Isometry3d> parseKittiPoses(std::string_view text, const std::string& name);
/// The x y z of a velodyne .bin (float32 x y z reflectance records); SourceError on a partial record or a
/// non-finite coordinate.
std::vector<Vec3f> parseKittiBin(std::string_view bytes, const std::string& name);

}  // namespace densemap::io
