// rosbag2's sqlite3 storage (the default before Iron): tables `topics` (name, type, serialization_format,
// offered_qos_profiles) and `messages` (topic_id, timestamp, data), read through Debian's libsqlite3,
// opened immutable so read-only media and bags being copied are safe.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "densemap/ros2/bag_reader.h"

struct sqlite3;

namespace densemap::ros2 {

class Rosbag2SqliteReader : public BagReader {
 public:
  /// One or more .db3 files of one bag, in order (a split bag has several).
  explicit Rosbag2SqliteReader(std::vector<std::string> files);
  ~Rosbag2SqliteReader() override;

  const std::vector<BagTopic>& topics() const override { return topics_; }
  const std::vector<BagMessageRef>& messages() const override { return messages_; }
  std::vector<std::uint8_t> readMessage(const BagMessageRef& message) const override;
  std::string describe() const override;

 private:
  struct Database;
  std::vector<std::unique_ptr<Database>> databases_;
  std::vector<BagTopic> topics_;
  std::vector<BagMessageRef> messages_;
};

}  // namespace densemap::ros2
