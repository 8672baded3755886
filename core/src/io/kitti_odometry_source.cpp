#include "densemap/io/kitti_odometry_source.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace densemap::io {

namespace fs = std::filesystem;

namespace {
Eigen::Isometry3d fromRow12(const std::vector<double>& v) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) t.linear()(r, c) = v[static_cast<std::size_t>(r * 4 + c)];
    t.translation()(r) = v[static_cast<std::size_t>(r * 4 + 3)];
  }
  return t;
}
}  // namespace

Eigen::Isometry3d KittiOdometrySource::readCalibration(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw SourceError(path + ": cannot open calibration file");
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream ls(line);
    std::string tag;
    ls >> tag;
    if (tag != "Tr:" && tag != "Tr_velo_to_cam:") continue;
    std::vector<double> v(12);
    for (double& x : v)
      if (!(ls >> x)) throw SourceError(path + ": 'Tr:' needs 12 numbers");
    return fromRow12(v);
  }
  throw SourceError(path + ": no 'Tr:' line (velodyne to camera transform)");
}

KittiOdometrySource::KittiOdometrySource(const std::string& dir) : dir_(dir) {
  if (!fs::is_directory(dir + "/velodyne")) throw SourceError(dir + ": no velodyne/ directory");
  for (const auto& e : fs::directory_iterator(dir + "/velodyne"))
    if (e.path().extension() == ".bin") bins_.push_back(e.path().string());
  std::sort(bins_.begin(), bins_.end());
  if (bins_.empty()) throw SourceError(dir + "/velodyne: no .bin scans");
  const Eigen::Isometry3d tr = readCalibration(dir + "/calib.txt");
  const Eigen::Isometry3d tr_inv = tr.inverse();
  std::ifstream in(dir + "/poses.txt");
  if (!in) throw SourceError(dir + "/poses.txt: cannot open (KITTI camera poses, 12 numbers per line)");
  std::string line;
  std::size_t n = 0;
  while (std::getline(in, line) && poses_.size() < bins_.size()) {
    ++n;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    std::istringstream ls(line);
    std::vector<double> v(12);
    for (double& x : v)
      if (!(ls >> x)) throw SourceError(dir + "/poses.txt: line " + std::to_string(n) + " needs 12 numbers");
    poses_.push_back(tr_inv * fromRow12(v) * tr);
  }
  if (poses_.size() < bins_.size())
    throw SourceError(dir + "/poses.txt: " + std::to_string(poses_.size()) + " poses for " +
                      std::to_string(bins_.size()) + " scans");
}

Scan KittiOdometrySource::read(std::size_t i) const {
  if (i >= bins_.size()) throw SourceError(dir_ + ": scan " + std::to_string(i) + " out of range");
  std::ifstream in(bins_[i], std::ios::binary | std::ios::ate);
  if (!in) throw SourceError(bins_[i] + ": cannot open");
  const auto bytes = static_cast<std::size_t>(in.tellg());
  if (bytes % 16 != 0)
    throw SourceError(bins_[i] + ": size is not a multiple of 16 bytes (x y z r float32): truncated?");
  in.seekg(0);
  std::vector<float> raw(bytes / 4);
  if (!in.read(reinterpret_cast<char*>(raw.data()), static_cast<std::streamsize>(bytes)))
    throw SourceError(bins_[i] + ": read failed");
  Scan s;
  s.index = i;
  s.frame = PointFrame::kSensor;
  s.pose = poses_[i];
  s.points.reserve(raw.size() / 4);
  for (std::size_t k = 0; k + 3 < raw.size(); k += 4) s.points.emplace_back(raw[k], raw[k + 1], raw[k + 2]);
  s.lidar = LidarGeometry{};  // HDL-64E
  return s;
}

std::string KittiOdometrySource::describe() const {
  return "KITTI odometry layout " + dir_ + " (" + std::to_string(bins_.size()) + " scans)";
}

}  // namespace densemap::io
