#include "densemap/io/viewpoint_pcd_source.h"

#include <algorithm>
#include <filesystem>
#include <regex>

#include "densemap/io/pcd_file.h"

namespace densemap::io {

namespace fs = std::filesystem;

ViewpointPcdSource::ViewpointPcdSource(const std::string& path) : path_(path) {
  if (fs::is_regular_file(path)) {
    files_.push_back(path);
    return;
  }
  if (!fs::is_directory(path)) throw SourceError(path + ": no such file or directory");
  static const std::regex numbered(R"((.*)_(\d+)\.pcd)");
  std::vector<std::pair<long, std::string>> found;
  for (const auto& e : fs::directory_iterator(path)) {
    std::smatch m;
    const std::string name = e.path().filename().string();
    if (std::regex_match(name, m, numbered)) found.emplace_back(std::stol(m[2].str()), e.path().string());
  }
  std::sort(found.begin(), found.end());
  for (auto& f : found) files_.push_back(f.second);
  if (files_.empty()) throw SourceError(path + ": no <name>_<k>.pcd files found");
}

Scan ViewpointPcdSource::read(std::size_t i) const {
  if (i >= files_.size()) throw SourceError(path_ + ": scan " + std::to_string(i) + " out of range");
  PcdData d = readPcd(files_[i]);
  Scan s;
  s.index = i;
  s.points = std::move(d.points);
  s.frame = PointFrame::kWorld;
  s.pose = Eigen::Isometry3d::Identity();
  s.pose.linear() = d.viewpoint_orientation.normalized().toRotationMatrix();
  s.pose.translation() = d.viewpoint;
  return s;
}

std::string ViewpointPcdSource::describe() const {
  return "world-frame PCD " + path_ + " (" + std::to_string(files_.size()) + " scans)";
}

}  // namespace densemap::io
