#include "densemap/io/kitti_odometry_source.h"

#include <cmath>
#include <cstring>
#include <filesystem>

#include <fmt/format.h>

#include "densemap/io/numbered_files.h"
#include "densemap/io/rigid_transform.h"
#include "densemap/io/text_parse.h"

namespace densemap::io {

namespace fs = std::filesystem;

namespace {
constexpr std::size_t kMaxTextFileBytes = std::size_t{1} << 30;  // poses.txt of 10^7 scans is ~1.3 GB
constexpr std::size_t kMaxBinBytes = std::size_t{1} << 32;

/// The lines of `text` (without their '\n').
std::vector<std::string_view> lines(std::string_view text) {
  std::vector<std::string_view> out;
  std::size_t pos = 0;
  while (pos < text.size()) {
    auto eol = text.find('\n', pos);
    if (eol == std::string_view::npos) eol = text.size();
    out.push_back(text.substr(pos, eol - pos));
    pos = eol + 1;
  }
  return out;
}
}  // namespace

Eigen::Isometry3d parseKittiCalibration(std::string_view text, const std::string& name) {
  const auto all = lines(text);
  for (std::size_t n = 0; n < all.size(); ++n) {
    auto words = splitWords(all[n]);
    if (words.empty() || (words[0] != "Tr:" && words[0] != "Tr_velo_to_cam:")) continue;
    words.erase(words.begin());
    return parseRigidRows(words, 3, fmt::format("{}: line {} (Tr, velodyne to camera)", name, n + 1));
  }
  throw SourceError(name + ": no 'Tr:' line (velodyne to camera transform)");
}

std::vector<Eigen::Isometry3d> parseKittiPoses(std::string_view text, const std::string& name) {
  const auto all = lines(text);
  std::size_t used = all.size();
  while (used > 0 && splitWords(all[used - 1]).empty()) --used;  // trailing blank lines
  std::vector<Eigen::Isometry3d> poses;
  poses.reserve(used);
  for (std::size_t n = 0; n < used; ++n) {
    const auto words = splitWords(all[n]);
    if (words.empty())
      throw SourceError(
          fmt::format("{}: line {} is blank; every scan needs its pose line (a blank line would "
                      "shift every later scan onto the wrong pose)",
                      name, n + 1));
    poses.push_back(parseRigidRows(words, 3, fmt::format("{}: line {} (pose of scan {})", name, n + 1, n)));
  }
  return poses;
}

std::vector<Vec3f> parseKittiBin(std::string_view bytes, const std::string& name) {
  if (bytes.size() % 16 != 0)
    throw SourceError(
        fmt::format("{}: {} bytes is not a whole number of 16-byte records (x y z reflectance "
                    "float32): truncated?",
                    name, bytes.size()));
  std::vector<Vec3f> points(bytes.size() / 16);
  for (std::size_t k = 0; k < points.size(); ++k) {
    float xyz[3];
    std::memcpy(xyz, bytes.data() + 16 * k, sizeof xyz);
    if (!std::isfinite(xyz[0]) || !std::isfinite(xyz[1]) || !std::isfinite(xyz[2]))
      throw SourceError(
          fmt::format("{}: point {} is ({} {} {}); KITTI scans hold only finite points (corrupt "
                      "file?)",
                      name, k, xyz[0], xyz[1], xyz[2]));
    points[k] = Vec3f(xyz[0], xyz[1], xyz[2]);
  }
  return points;
}

Eigen::Isometry3d KittiOdometrySource::readCalibration(const std::string& path) {
  return parseKittiCalibration(readFileBytes(path, kMaxTextFileBytes, "calibration file"), path);
}

KittiOdometrySource::KittiOdometrySource(const std::string& dir, const SourceOptions& options) : dir_(dir) {
  if (!fs::is_directory(dir + "/velodyne")) throw SourceError(dir + ": no velodyne/ directory");
  const auto bins = listNumberedFiles(dir + "/velodyne", ".bin", options.allow_gaps);
  if (bins.front().number != 0 && !options.allow_gaps)
    throw SourceError(dir + "/velodyne: scan 0 is missing (the first is " +
                      std::to_string(bins.front().number) +
                      "); restore it, or pass --allow-gaps to map only the scans that are there");
  const Eigen::Isometry3d tr = readCalibration(dir + "/calib.txt");
  const Eigen::Isometry3d tr_inv = tr.inverse();
  const auto camera_poses = parseKittiPoses(
      readFileBytes(dir + "/poses.txt", kMaxTextFileBytes, "KITTI poses file"), dir + "/poses.txt");
  if (camera_poses.size() <= bins.back().number)
    throw SourceError(fmt::format("{}/poses.txt: {} poses, but velodyne/ has scan {}", dir,
                                  camera_poses.size(), bins.back().number));
  for (const auto& b : bins) {
    bins_.push_back(b.path);
    poses_.push_back(tr_inv * camera_poses[b.number] * tr);
  }
}

Scan KittiOdometrySource::read(std::size_t i) const {
  if (i >= bins_.size()) throw SourceError(dir_ + ": scan " + std::to_string(i) + " out of range");
  Scan s;
  s.index = i;
  s.frame = PointFrame::kSensor;
  s.pose = poses_[i];
  s.points = parseKittiBin(readFileBytes(bins_[i], kMaxBinBytes, "KITTI velodyne scan"), bins_[i]);
  s.lidar = LidarGeometry{};  // HDL-64E
  return s;
}

std::string KittiOdometrySource::describe() const {
  return "KITTI odometry layout " + dir_ + " (" + std::to_string(bins_.size()) + " scans)";
}

}  // namespace densemap::io
