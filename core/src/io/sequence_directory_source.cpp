#include "densemap/io/sequence_directory_source.h"

#include <filesystem>
#include <fstream>

#include "densemap/io/pcd_file.h"

namespace densemap::io {

namespace fs = std::filesystem;

Eigen::Isometry3d readPoseMatrix(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw SourceError(path + ": cannot open pose file");
  Eigen::Matrix4d m;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c)
      if (!(in >> m(r, c))) throw SourceError(path + ": pose file must hold 16 numbers (4x4 row-major)");
  if (!m.allFinite()) throw SourceError(path + ": pose has non-finite entries");
  const Eigen::Matrix3d rot = m.topLeftCorner<3, 3>();
  if ((rot * rot.transpose() - Eigen::Matrix3d::Identity()).norm() > 1e-3 || rot.determinant() < 0)
    throw SourceError(path + ": pose rotation is not orthonormal");
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = rot;
  pose.translation() = m.topRightCorner<3, 1>();
  return pose;
}

SequenceDirectorySource::SequenceDirectorySource(std::string dir) : dir_(std::move(dir)) {
  if (!fs::is_directory(dir_ + "/clouds") || !fs::is_directory(dir_ + "/poses"))
    throw SourceError(dir_ + ": not a sequence directory (needs clouds/ and poses/)");
  while (fs::exists(dir_ + "/clouds/" + std::to_string(count_) + ".pcd")) ++count_;
  if (count_ == 0) throw SourceError(dir_ + ": clouds/0.pcd not found");
}

Scan SequenceDirectorySource::read(std::size_t i) const {
  if (i >= count_)
    throw SourceError(dir_ + ": scan " + std::to_string(i) + " out of range (" + std::to_string(count_) +
                      " scans)");
  Scan s;
  s.index = i;
  s.points = readPcd(dir_ + "/clouds/" + std::to_string(i) + ".pcd").points;
  s.pose = readPoseMatrix(dir_ + "/poses/" + std::to_string(i) + ".txt");
  s.frame = PointFrame::kSensor;
  return s;
}

std::string SequenceDirectorySource::describe() const {
  return "sequence directory " + dir_ + " (" + std::to_string(count_) + " scans)";
}

}  // namespace densemap::io
