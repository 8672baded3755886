#include "densemap/ros2/bag_reader.h"

#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <fstream>
#include <sstream>

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

BagMetadata parseBagMetadata(const std::string& yaml, const std::string& name) {
  try {
    const YAML::Node top = YAML::Load(yaml);
    const YAML::Node root = top.IsMap() ? top["rosbag2_bagfile_information"] : YAML::Node();
    if (!root || !root.IsMap())
      throw BagError(name + ": has no rosbag2_bagfile_information (not a rosbag2 bag?)");
    BagMetadata m;
    m.storage = root["storage_identifier"] ? root["storage_identifier"].as<std::string>() : "";
    const std::string compression =
        root["compression_format"] ? root["compression_format"].as<std::string>() : "";
    if (!compression.empty())
      throw BagError(
          name + ": the bag is compressed per " +
          (root["compression_mode"] ? root["compression_mode"].as<std::string>() : std::string("?")) +
          " with " + compression +
          "; densemap reads uncompressed rosbag2 bags and MCAP's own chunk compression "
          "(run `ros2 bag decompress`, or record with --storage mcap)");
    if (m.storage != "sqlite3" && m.storage != "mcap")
      throw BagError(name + ": storage '" + m.storage + "' (densemap reads sqlite3 and mcap)");
    const YAML::Node paths = root["relative_file_paths"];
    if (paths && !paths.IsSequence()) throw BagError(name + ": relative_file_paths is not a list");
    if (paths)
      for (const auto& f : paths) {
        const fs::path relative = f.as<std::string>();
        // A hostile metadata file must not send us outside the bag's directory.
        if (relative.empty() || relative.is_absolute() ||
            relative.lexically_normal().string().rfind("..", 0) == 0)
          throw BagError(name + ": file '" + relative.string() + "' is outside the bag's directory");
        m.files.push_back(relative.string());
      }
    if (m.files.empty()) throw BagError(name + ": names no files (relative_file_paths)");
    return m;
  } catch (const YAML::Exception& e) {
    throw BagError(name + ": not readable as rosbag2 metadata (" + e.what() + ")");
  }
}

namespace {

std::unique_ptr<BagReader> openDirectory(const fs::path& dir) {
  const fs::path metadata = dir / "metadata.yaml";
  std::ifstream in(metadata);
  if (!in) throw BagError(metadata.string() + ": cannot be read");
  std::stringstream text;
  text << in.rdbuf();
  if (text.str().size() > (16u << 20))
    throw BagError(metadata.string() + ": larger than 16 MB (not rosbag2 metadata)");
  const BagMetadata m = parseBagMetadata(text.str(), metadata.string());
  std::vector<std::string> files;
  for (const auto& f : m.files) {
    files.push_back((dir / f).string());
    if (!fs::is_regular_file(files.back()))
      throw BagError(metadata.string() + ": its file " + files.back() + " is missing");
  }
  if (m.storage == "sqlite3") return std::make_unique<Rosbag2SqliteReader>(files);
  if (files.size() != 1)
    throw BagError(metadata.string() + ": a split MCAP bag (" + std::to_string(files.size()) +
                   " files); give one of its .mcap files");
  return std::make_unique<McapReader>(files.front());
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
