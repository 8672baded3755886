// MCAP (https://mcap.dev/spec), the ROS 2 bag format since Iron, read by the project's own small reader
// (the container has no Debian package): records in the data section and in chunks (uncompressed, zstd
// or lz4 frames), each chunk's CRC checked. The summary section is not needed: the data section is
// indexed once at open.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <vector>

#include "densemap/ros2/bag_reader.h"

namespace densemap::ros2 {

class McapReader : public BagReader {
 public:
  /// Reads and indexes a file (throws BagError naming it and the offset of what is wrong).
  explicit McapReader(const std::string& path);
  /// Reads and indexes bytes already in memory (the fuzz target's entry point); `name` names them in errors.
  McapReader(std::vector<std::uint8_t> bytes, std::string name);

  const std::vector<BagTopic>& topics() const override { return topics_; }
  const std::vector<BagMessageRef>& messages() const override { return messages_; }
  std::vector<std::uint8_t> readMessage(const BagMessageRef& message) const override;
  std::string describe() const override;

 private:
  struct Chunk {
    std::uint64_t records_offset = 0;  ///< where the (compressed) records start in the file
    std::uint64_t records_size = 0;
    std::uint64_t uncompressed_size = 0;
    std::uint32_t uncompressed_crc = 0;
    std::string compression;
  };
  void index();
  /// Records in `records`; `base` locates them for errors; `chunk` is -1 outside chunks.
  void indexRecords(std::span<const std::uint8_t> records, std::uint64_t base, std::int64_t chunk);
  std::vector<std::uint8_t> chunkRecords(std::size_t chunk) const;
  std::uint16_t topicOfChannel(std::uint16_t channel, std::uint64_t at) const;

  std::string name_;
  std::vector<std::uint8_t> owned_;      ///< bytes given in memory
  std::shared_ptr<const void> mapping_;  ///< or the file, mapped read-only
  std::span<const std::uint8_t> bytes_;
  std::vector<Chunk> chunks_;
  std::map<std::uint16_t, std::pair<std::string, std::string>> schemas_;  ///< id -> (name, encoding)
  std::map<std::uint16_t, std::size_t> channel_topic_;                    ///< channel id -> topics_ index
  std::vector<BagTopic> topics_;
  std::vector<BagMessageRef> messages_;
  mutable std::mutex cache_mutex_;
  mutable std::int64_t cached_chunk_ = -1;
  mutable std::vector<std::uint8_t> cached_records_;
};

}  // namespace densemap::ros2
