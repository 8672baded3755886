// What densemap reads from a ROS 2 recording, whatever its storage: its topics (name, type, recorded
// QoS) and its messages (topic, log time, the CDR bytes as a ROS 2 node sent them).
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

namespace densemap::ros2 {

struct BagTopic {
  std::string name;                  ///< "/points"
  std::string type;                  ///< "sensor_msgs/msg/PointCloud2"
  std::string serialization_format;  ///< "cdr"
  std::string offered_qos_profiles;  ///< rosbag2's YAML of the publishers' QoS ("" when not recorded)
};

/// One message: where it is, not its bytes (readMessage fetches them), so a bag is indexed without
/// holding it in memory.
struct BagMessageRef {
  std::size_t topic = 0;  ///< index into topics()
  std::int64_t log_time_ns = 0;
  std::uint64_t locator = 0;  ///< storage-specific
};

/// A recording that cannot be read; the message names the file and, where one applies, the offset.
class BagError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class BagReader {
 public:
  virtual ~BagReader() = default;
  virtual const std::vector<BagTopic>& topics() const = 0;
  /// Every message, in log-time order (ties in storage order).
  virtual const std::vector<BagMessageRef>& messages() const = 0;
  virtual std::vector<std::uint8_t> readMessage(const BagMessageRef& message) const = 0;
  virtual std::string describe() const = 0;
};

/// What a rosbag2 directory's metadata.yaml says: the storage ("sqlite3", "mcap") and its files, relative to
/// the directory (checked not to leave it). Throws BagError naming `name` (unreadable YAML, a compressed
/// bag, no files, a path outside the directory).
struct BagMetadata {
  std::string storage;
  std::vector<std::string> files;
};
BagMetadata parseBagMetadata(const std::string& yaml, const std::string& name);

/// True when `path` looks like a ROS 2 recording: a .mcap or .db3 file, or a directory holding
/// metadata.yaml (rosbag2).
bool isBag(const std::string& path);
/// Opens an MCAP file, a rosbag2 sqlite3 file, or a rosbag2 directory (its metadata.yaml names the
/// storage, sqlite3 or mcap, and the files). Throws BagError.
std::unique_ptr<BagReader> openBag(const std::string& path);

}  // namespace densemap::ros2
