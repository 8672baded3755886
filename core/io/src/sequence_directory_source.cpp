#include "densemap/io/sequence_directory_source.h"

#include <filesystem>

#include "densemap/io/pcd_file.h"
#include "densemap/io/rigid_transform.h"
#include "densemap/io/text_parse.h"

namespace densemap::io {

namespace fs = std::filesystem;

namespace {
/// A pose file is 16 numbers; a megabyte is far more than any holds.
constexpr std::size_t kMaxPoseFileBytes = 1 << 20;
}  // namespace

Eigen::Isometry3d parsePoseMatrix(std::string_view text, const std::string& name) {
  return parseRigidRows(splitWords(text), 4, name + ": pose");
}

Eigen::Isometry3d readPoseMatrix(const std::string& path) {
  return parsePoseMatrix(readFileBytes(path, kMaxPoseFileBytes, "pose file"), path);
}

SequenceDirectorySource::SequenceDirectorySource(std::string dir, const SourceOptions& options)
    : dir_(std::move(dir)) {
  if (!fs::is_directory(dir_ + "/clouds") || !fs::is_directory(dir_ + "/poses"))
    throw SourceError(dir_ + ": not a sequence directory (needs clouds/ and poses/)");
  clouds_ = listNumberedFiles(dir_ + "/clouds", ".pcd", options.allow_gaps);
  if (clouds_.front().number != 0 && !options.allow_gaps)
    throw SourceError(dir_ + "/clouds: scan 0 is missing (the first is " +
                      std::to_string(clouds_.front().number) +
                      "); restore it, or pass --allow-gaps to map only the scans that are there");
  for (const auto& c : clouds_) {
    const std::string pose = dir_ + "/poses/" + std::to_string(c.number) + ".txt";
    if (!fs::is_regular_file(pose))
      throw SourceError(pose + ": missing; every clouds/<i>.pcd needs its poses/<i>.txt");
  }
}

Scan SequenceDirectorySource::read(std::size_t i) const {
  if (i >= clouds_.size())
    throw SourceError(dir_ + ": scan " + std::to_string(i) + " out of range (" +
                      std::to_string(clouds_.size()) + " scans)");
  Scan s;
  s.index = i;
  PcdData cloud = readPcd(clouds_[i].path);
  s.points = std::move(cloud.points);
  s.nonfinite_points = cloud.nonfinite_points;
  s.pose = readPoseMatrix(dir_ + "/poses/" + std::to_string(clouds_[i].number) + ".txt");
  s.frame = PointFrame::kSensor;
  return s;
}

std::string SequenceDirectorySource::describe() const {
  return "sequence directory " + dir_ + " (" + std::to_string(clouds_.size()) + " scans)";
}

}  // namespace densemap::io
