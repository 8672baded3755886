#include "densemap/ros2/bag_reader.h"

#include <yaml-cpp/yaml.h>

#include <filesystem>

#include "densemap/ros2/mcap_reader.h"
#include "densemap/ros2/rosbag2_sqlite_reader.h"

namespace densemap::ros2 {

namespace fs = std::filesystem;

bool isBag(const std::string& path) {
  std::error_code ec;
  if (fs::is_directory(path, ec)) return fs::exists(fs::path(path) / "metadata.yaml", ec);
  const std::string ext = fs::path(path).extension().string();
  return ext == ".mcap" || ext == ".db3";
}

namespace {

std::unique_ptr<BagReader> openDirectory(const fs::path& dir) {
  const fs::path metadata = dir / "metadata.yaml";
  YAML::Node root;
  try {
    root = YAML::LoadFile(metadata.string())["rosbag2_bagfile_information"];
  } catch (const YAML::Exception& e) {
    throw BagError(metadata.string() + ": not readable as rosbag2 metadata (" + e.what() + ")");
  }
  if (!root) throw BagError(metadata.string() + ": has no rosbag2_bagfile_information (not a rosbag2 bag?)");
  try {
    const std::string storage =
        root["storage_identifier"] ? root["storage_identifier"].as<std::string>() : "";
    const std::string compression =
        root["compression_format"] ? root["compression_format"].as<std::string>() : "";
    if (!compression.empty())
      throw BagError(
          metadata.string() + ": the bag is compressed per " +
          (root["compression_mode"] ? root["compression_mode"].as<std::string>() : std::string("?")) +
          " with " + compression +
          "; densemap reads uncompressed rosbag2 bags and MCAP's own chunk compression "
          "(run `ros2 bag decompress`, or record with --storage mcap)");
    std::vector<std::string> files;
    for (const auto& f : root["relative_file_paths"]) {
      const fs::path relative = f.as<std::string>();
      // A hostile metadata file must not send us outside the bag's directory.
      if (relative.is_absolute() || relative.lexically_normal().string().rfind("..", 0) == 0)
        throw BagError(metadata.string() + ": file '" + relative.string() +
                       "' is outside the bag's directory");
      files.push_back((dir / relative).string());
    }
    if (files.empty()) throw BagError(metadata.string() + ": names no files (relative_file_paths)");
    for (const auto& f : files)
      if (!fs::is_regular_file(f)) throw BagError(metadata.string() + ": its file " + f + " is missing");
    if (storage == "sqlite3") return std::make_unique<Rosbag2SqliteReader>(files);
    if (storage == "mcap") {
      if (files.size() != 1)
        throw BagError(metadata.string() + ": a split MCAP bag (" + std::to_string(files.size()) +
                       " files); give one of its .mcap files");
      return std::make_unique<McapReader>(files.front());
    }
    throw BagError(metadata.string() + ": storage '" + storage + "' (densemap reads sqlite3 and mcap)");
  } catch (const YAML::Exception& e) {
    throw BagError(metadata.string() + ": " + e.what());
  }
}

}  // namespace

std::unique_ptr<BagReader> openBag(const std::string& path) {
  std::error_code ec;
  if (fs::is_directory(path, ec)) return openDirectory(path);
  if (!fs::is_regular_file(path, ec)) throw BagError(path + ": no such bag file or directory");
  const std::string ext = fs::path(path).extension().string();
  if (ext == ".mcap") return std::make_unique<McapReader>(path);
  if (ext == ".db3") return std::make_unique<Rosbag2SqliteReader>(std::vector<std::string>{path});
  throw BagError(path + ": not a ROS 2 bag (expected a .mcap, a .db3 or a rosbag2 directory)");
}

}  // namespace densemap::ros2
