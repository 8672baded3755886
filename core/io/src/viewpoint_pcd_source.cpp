#include "densemap/io/viewpoint_pcd_source.h"

#include <filesystem>

#include "densemap/io/numbered_files.h"
#include "densemap/io/pcd_file.h"

namespace densemap::io {

namespace fs = std::filesystem;

ViewpointPcdSource::ViewpointPcdSource(const std::string& path, const SourceOptions& options) : path_(path) {
  if (fs::is_regular_file(path)) {
    files_.push_back(path);
    return;
  }
  if (!fs::is_directory(path)) throw SourceError(path + ": no such file or directory");
  for (auto& f : listNumberedFiles(path, ".pcd", options.allow_gaps)) files_.push_back(std::move(f.path));
}

Scan ViewpointPcdSource::read(std::size_t i) const {
  if (i >= files_.size()) throw SourceError(path_ + ": scan " + std::to_string(i) + " out of range");
  PcdData d = readPcd(files_[i]);
  Scan s;
  s.index = i;
  s.points = std::move(d.points);
  s.nonfinite_points = d.nonfinite_points;
  s.frame = PointFrame::kWorld;
  s.pose = Eigen::Isometry3d::Identity();
  s.pose.linear() = d.viewpoint_orientation.toRotationMatrix();
  s.pose.translation() = d.viewpoint;
  return s;
}

std::string ViewpointPcdSource::describe() const {
  return "world-frame PCD " + path_ + " (" + std::to_string(files_.size()) + " scans)";
}

}  // namespace densemap::io
