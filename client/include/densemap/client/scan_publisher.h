// The robot side of the scan topics: publishes core scans as DDS messages, each robot on its own
// densemap/scans/<robot_id>, and follows the server's per-scan acknowledgements and progress on the robot's
// own densemap/scan_acks/<robot_id> and densemap/robot_progress/<robot_id> (msg/peer_topic.h: in secure mode
// the permissions let only the robot's identity use them), and the server's statistics.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "densemap/client/statistics_subscriber.h"
#include "densemap/io/scan.h"
#include "densemap/msg/dds_node.h"
#include "densemap/msg/wire_types.h"

namespace densemap::client {

struct AckCounts {
  std::uint64_t applied = 0;
  std::uint64_t rejected = 0;
  std::uint64_t dropped = 0;
  std::uint64_t duplicate = 0;  ///< resends the server had in its map already
  std::uint64_t durable = 0;    ///< acknowledgements that say the scan is on the server's disk
  std::uint64_t total() const { return applied + rejected + dropped + duplicate; }
};

class ScanPublisher {
 public:
  /// Makes the topics of `robot_ids` (more are made at their first publish). Throws std::invalid_argument for
  /// an id that cannot name a topic, msg::DdsError when DDS (or the identity's permissions) refuses one.
  ScanPublisher(msg::DdsNode& node, const std::vector<std::string>& robot_ids);
  ~ScanPublisher();
  ScanPublisher(const ScanPublisher&) = delete;
  ScanPublisher& operator=(const ScanPublisher&) = delete;

  /// Waits until a server subscribes to every robot's scans (and publishes its acks); false on timeout.
  bool waitForServer(std::chrono::milliseconds timeout);
  /// When waitForServer first saw the writer and the acknowledgement reader matched both ways (in secure
  /// mode: after the server authenticated this participant and granted its permissions).
  std::optional<std::chrono::steady_clock::time_point> matchedAt() const { return matched_at_; }
  /// What waitForServer is still waiting for, per robot (for the message when it times out): how many
  /// server readers the scan writer matched, how many server writers the acknowledgement reader matched,
  /// and whether a statistics message arrived.
  std::string joinState();

  /// Publishes one scan for `robot_id`: sensor-frame points (or world-frame points when the scan is in the
  /// world frame, sent with frame_id "world"), the pose as position + unit quaternion, the LiDAR geometry.
  /// Blocks while the server is behind and the writer's history is full (reliable back-pressure).
  /// Returns false when DDS refused the sample. Thread-safe. A robot not given to the constructor gets its
  /// topics now, and the call waits (up to 10 s) until the server reads them.
  bool publish(const std::string& robot_id, std::uint64_t seq, const io::Scan& scan);
  /// Publishes a raw message as is (tests use it to send malformed scans), on the topic of `as_robot` (empty:
  /// of the message's robot id).
  bool publishRaw(msg::Scan& m, const std::string& as_robot = "");

  /// Waits until `expected` acknowledgements arrived for these robots, or the timeout passes.
  AckCounts waitForAcks(const std::set<std::string>& robots, std::uint64_t expected,
                        std::chrono::milliseconds timeout);
  AckCounts acks(const std::set<std::string>& robots) const;
  /// The acknowledgement of one scan, if it arrived.
  std::optional<msg::ScanAck> ack(const std::string& robot_id, std::uint64_t seq) const;
  /// Publish-to-map latencies (ms) of the applied scans of these robots.
  std::vector<double> latenciesMs(const std::set<std::string>& robots) const;
  /// Called (on a DDS thread, one at a time) for every acknowledgement as it arrives, e.g. to log it.
  void setAckObserver(std::function<void(const msg::ScanAck&)> observer);
  /// The server's last progress message for this robot (what it keeps of it), if one arrived.
  std::optional<msg::RobotProgress> progress(const std::string& robot_id) const;
  /// Waits up to `timeout` for this robot's progress (from a server other than `incarnation`, when given).
  std::optional<msg::RobotProgress> waitForProgress(const std::string& robot_id,
                                                    std::chrono::milliseconds timeout,
                                                    std::optional<std::uint64_t> not_incarnation = {});
  /// The last statistics message from the server, if one arrived.
  std::optional<msg::ServerStatistics> lastStatistics() const;
  /// Waits for a statistics message newer than now in which these robots' counts add up to `expected`.
  std::optional<msg::ServerStatistics> waitForStatistics(const std::set<std::string>& robots,
                                                         std::uint64_t expected,
                                                         std::chrono::milliseconds timeout);

 private:
  class Listener;
  // One robot's topics. Entries are made, never removed, until the publisher goes.
  struct Robot {
    std::string id;
    std::unique_ptr<Listener> listener;
    eprosima::fastdds::dds::DataWriter* writer = nullptr;
    eprosima::fastdds::dds::DataReader* ack_reader = nullptr;
    eprosima::fastdds::dds::DataReader* progress_reader = nullptr;
  };
  Robot& robot(const std::string& robot_id, bool* made = nullptr);
  std::unique_ptr<Robot> makeRobot(const std::string& robot_id);
  void removeRobots();
  void onAcks(eprosima::fastdds::dds::DataReader* reader);
  void onProgress(const std::string& robot_id, eprosima::fastdds::dds::DataReader* reader);

  msg::DdsNode& node_;
  std::mutex robots_mutex_;  // taken before mutex_, never while DDS calls a listener
  std::map<std::string, std::unique_ptr<Robot>> robots_;  // guarded by robots_mutex_
  std::map<std::string, msg::RobotProgress> progress_;    // guarded by mutex_
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::map<std::pair<std::string, std::uint64_t>, msg::ScanAck> acks_;
  std::function<void(const msg::ScanAck&)> ack_observer_;
  // Made after the robots' topics: see the constructor.
  std::unique_ptr<StatisticsSubscriber> statistics_;
  std::optional<std::chrono::steady_clock::time_point> matched_at_;
};

/// The DDS message for a scan: sensor-frame points (or world-frame points with frame_id "world"), the pose
/// as position + unit quaternion, the LiDAR geometry when known. publish_ns is set when it is published.
msg::Scan toMessage(const std::string& robot_id, std::uint64_t seq, const io::Scan& scan);

/// Sum of these robots' counters in a statistics message.
struct RobotTotals {
  std::uint64_t received = 0, processed = 0, dropped = 0, rejected = 0;
};
RobotTotals totalsFor(const msg::ServerStatistics& s, const std::set<std::string>& robots);

/// A robot's last durable sequence number in a progress message (nullopt: the server has none of it).
std::optional<std::uint64_t> lastDurableSeq(const msg::RobotProgress& p, const std::string& robot_id);
/// True when a progress message shows (robot, seq) durable on the server. False also when the message's
/// intervals do not reach back that far: then the scan is resent, and the server refuses it if it has it.
bool heldDurably(const msg::RobotProgress& p, const std::string& robot_id, std::uint64_t seq);

}  // namespace densemap::client
