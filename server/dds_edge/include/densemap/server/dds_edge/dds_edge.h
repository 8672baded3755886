// densemap's DDS edge: takes each robot's scans from densemap/scans/<robot_id> into the MapService, answers
// queries on densemap/query/* and commands on densemap/admin/*, acknowledges every scan on the robot's own
// densemap/scan_acks/<robot_id>, and publishes statistics and progress.
// Its threads: DDS's own (cheap queries are answered there), scan intake, query workers, one admin
// worker (commands run one at a time, in arrival order), acknowledgements, statistics.
#pragma once

#include <atomic>
#include <condition_variable>
#include <deque>
#include <memory>
#include <mutex>
#include <set>
#include <thread>
#include <vector>

#include "densemap/msg/dds_node.h"
#include "densemap/msg/wire_types.h"
#include "densemap/server/dds_edge/dds_edge_options.h"
#include "densemap/server/dds_edge/reply_writers.h"
#include "densemap/server/dds_edge/scan_readers.h"
#include "densemap/server/map_service.h"
#include "densemap/util/log_throttle.h"

namespace densemap::server::dds_edge {

/// Another densemap-server already serves these topics (same domain and namespace).
class AnotherServerError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class DdsEdge {
 public:
  /// Creates the DDS entities and starts serving `service` (which must outlive the edge). Throws
  /// msg::DdsError or std::invalid_argument (with a message saying which option is wrong).
  DdsEdge(MapService& service, const DdsEdgeOptions& options);
  ~DdsEdge();
  DdsEdge(const DdsEdge&) = delete;
  DdsEdge& operator=(const DdsEdge&) = delete;

  /// Clean shutdown: stop taking scans, stop the service (draining or dropping its queues as it is
  /// configured, acknowledging each scan), refuse and acknowledge the scans DDS still holds, publish the
  /// last statistics, stop answering, and wait (ack_flush_s) until robots have the acknowledgements.
  /// Every scan taken from DDS is acknowledged exactly once. Idempotent.
  void stop();

  MapService& service() { return service_; }
  /// True once another server on the same topics that started earlier was seen: this one should stop.
  bool refused() const { return refused_; }
  /// Remote participants refused by DDS-Security so far (failed authentication or permissions).
  std::uint64_t participantsRefused() const;
  /// Endpoints on per-peer topics whose name is no escape of a valid id (msg/peer_topic.h), ignored.
  std::uint64_t peerTopicsRefused() const;
  /// Other servers seen on the same topics so far.
  std::size_t otherServersSeen() const {
    std::lock_guard lock(peers_mutex_);
    return other_servers_.size();
  }

 private:
  class Listener;
  class DiscoveryListener;
  void ingestLoop();
  void takeQueries();
  void queryLoop();
  void takeCommands();
  void adminLoop();
  void ackLoop();
  /// Every robot's progress (the operator's topic) and, for each of `robots`, its own.
  void publishProgress(const std::set<std::string>& robots = {});
  void writeRobotProgress(const std::string& robot, eprosima::fastdds::dds::DataWriter& writer);
  void statisticsLoop();
  void queueAck(const ScanJob& job, ScanOutcome outcome, const std::string& why);
  std::size_t refuseScansStillInDds();
  void replyBusy(const msg::QueryRequest& rq);
  void writeReply(msg::QueryReply& rp);
  /// writeReply() on the client's writer if it exists (never makes one); false if it does not yet.
  bool writeReplyIfMade(msg::QueryReply& rp);
  void checkForAnotherServer();
  void takeStatistics();
  void writeAdminReply(msg::AdminReply& rp);
  void logRefusedClient(const std::string& client_id, const char* what);
  /// The service's statistics on the wire, with what only the edge counts (refused participants).
  msg::ServerStatistics statisticsMessage(const ServiceStatistics& s) const;
  bool isLargeQuery(const msg::QueryRequest& rq) const;

  MapService& service_;
  DdsEdgeOptions options_;
  std::unique_ptr<Listener> listener_;
  std::unique_ptr<DiscoveryListener> discovery_;
  std::unique_ptr<msg::DdsNode> node_;
  // Replies, on a topic per client (made before the readers that take requests, removed after them), and
  // acknowledgements and progress on a topic per robot.
  std::unique_ptr<ReplyWriters> replies_, admin_replies_, acks_, robot_progress_;
  std::unique_ptr<ScanReaders> scans_;  // the intake thread's (and stop()'s once it has ended)
  eprosima::fastdds::dds::DataReader* query_reader_ = nullptr;
  eprosima::fastdds::dds::DataReader* admin_reader_ = nullptr;
  eprosima::fastdds::dds::DataReader* stats_reader_ = nullptr;  // other servers' statistics
  eprosima::fastdds::dds::DataWriter* stats_writer_ = nullptr;
  eprosima::fastdds::dds::DataWriter* progress_writer_ = nullptr;
  std::uint64_t incarnation_ = 0;

  std::mutex wake_mutex_;
  std::condition_variable scans_ready_, queries_ready_, commands_ready_, acks_ready_, stats_wake_;
  std::atomic<bool> running_{true};
  std::atomic<std::int64_t> large_reply_ns_{0};
  util::LogThrottle refused_client_log_;
  mutable std::mutex peers_mutex_;
  std::vector<eprosima::fastdds::dds::InstanceHandle_t> other_servers_;  // their statistics writers
  std::int64_t started_ns_ = 0;                                          // the service's start
  std::atomic<bool> refused_{false};
  std::string
      refused_by_;  // guarded by peers_mutex_  // when the last large reply was written (0: trimmed since)
  bool workers_running_ = true;                  // query, admin and ack threads; guarded by wake_mutex_
  std::deque<msg::QueryRequest> query_backlog_;  // guarded by wake_mutex_
  std::deque<msg::AdminRequest> admin_backlog_;  // guarded by wake_mutex_
  std::deque<msg::ScanAck> ack_backlog_;         // guarded by wake_mutex_
  std::thread ingest_thread_, admin_thread_, ack_thread_, stats_thread_;
  std::vector<std::thread> query_threads_;
  std::mutex stop_mutex_;
  bool stopped_ = false;
};

}  // namespace densemap::server::dds_edge
