// The server's side of the per-robot scan topics (densemap/scans/<robot_id>, msg/peer_topic.h): a reader
// per robot, made when the robot's scan writer is discovered, removed when the robot is gone. The topic
// names the robot: DDS-Security permissions let only that robot's identity write it, so a scan's robot id
// is checked against its topic and a robot cannot send scans as another. Bounded: a flood of
// writers on new topics makes at most max_robots readers.
//
// Used by one thread (the scan intake), except writerDiscovered(), which DDS's discovery thread calls.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include "densemap/msg/dds_node.h"
#include "densemap/msg/wire_types.h"

namespace densemap::server::dds_edge {

class ScanReaders {
 public:
  /// `wake`: called (from any thread, never blocking) when a reader has data or a robot was discovered.
  ScanReaders(msg::DdsNode& node, std::size_t max_robots, std::function<void()> wake);
  ~ScanReaders();
  ScanReaders(const ScanReaders&) = delete;
  ScanReaders& operator=(const ScanReaders&) = delete;

  /// A writer on some topic was discovered (DDS's discovery thread): a reader is made at the next take()
  /// when the topic is a robot's scan topic. Never blocks on DDS.
  void writerDiscovered(const std::string& wire_topic);

  /// Makes the readers of newly discovered robots, removes those of robots gone for a while, and takes the
  /// next scan, robots in turn (one robot's backlog does not hold up the others). `robot`: whose topic it
  /// came from. False when no reader holds a scan.
  bool take(msg::Scan& scan, std::string& robot);

  /// Robots with a reader now.
  std::size_t size() const;
  /// Scan topics not read because max_robots readers existed.
  std::uint64_t refused() const { return refused_; }

  /// Removes every reader: what they still hold is lost, so take() until false first.
  void removeAll();

 private:
  class Listener;
  struct Entry {
    eprosima::fastdds::dds::DataReader* reader = nullptr;
    std::chrono::steady_clock::time_point unmatched_since;  // or the reader's creation
  };
  void adoptDiscovered();
  void removeIdle();

  msg::DdsNode& node_;
  const std::string wire_base_;
  const std::size_t max_robots_;
  std::function<void()> wake_;
  std::unique_ptr<Listener> listener_;
  std::map<std::string, Entry> readers_;  // by robot id
  std::map<std::string, Entry>::iterator next_;
  std::chrono::steady_clock::time_point last_idle_check_;
  std::uint64_t refused_ = 0;
  std::mutex pending_mutex_;          // the only lock writerDiscovered() takes
  std::set<std::string> discovered_;  // robots to make readers for; guarded by pending_mutex_
};

}  // namespace densemap::server::dds_edge
