// densemap-server's DDS node: takes scans from the scan topic into the pipeline, answers queries on the
// request-reply topics, acknowledges every scan and publishes statistics. The only place where the
// server converts between DDS messages and core types.
#pragma once

#include <atomic>
#include <condition_variable>
#include <deque>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "densemap/msg/densemap.h"
#include "densemap/server/dense_stage.h"
#include "densemap/server/map_store.h"
#include "densemap/server/pipeline.h"
#include "densemap/server/query_service.h"
#include "densemap/server/server_options.h"

namespace densemap::server {

class MappingServer {
 public:
  /// Creates the map, the pipeline and the DDS entities and starts serving. Throws msg::DdsError or
  /// std::invalid_argument (with a message saying which option is wrong).
  explicit MappingServer(const ServerOptions& options);
  ~MappingServer();
  MappingServer(const MappingServer&) = delete;
  MappingServer& operator=(const MappingServer&) = delete;

  /// Clean shutdown: stop taking scans, drain (or drop, counted) the queues, save if configured, stop the
  /// query threads. Idempotent.
  void stop();

  msg::ServerStatistics statistics() const;
  MapStore& store() { return *store_; }
  /// The dense layer, or null when the server runs none.
  DenseStore* denseStore() { return dense_store_.get(); }
  const ServerOptions& options() const { return options_; }

 private:
  class Listener;
  void ingestLoop();
  void takeQueries(eprosima::fastdds::dds::DataReader* reader);
  void queryLoop();
  void statisticsLoop();
  void onOutcome(const ScanJob& job, ScanOutcome outcome, const std::string& why);

  ServerOptions options_;
  std::unique_ptr<MapStore> store_;
  std::unique_ptr<DenseStore> dense_store_;
  std::unique_ptr<Pipeline> pipeline_;
  std::unique_ptr<QueryService> query_service_;
  std::unique_ptr<Listener> listener_;
  std::unique_ptr<msg::DdsNode> node_;
  eprosima::fastdds::dds::DataReader* scan_reader_ = nullptr;
  eprosima::fastdds::dds::DataReader* query_reader_ = nullptr;
  eprosima::fastdds::dds::DataWriter* ack_writer_ = nullptr;
  eprosima::fastdds::dds::DataWriter* reply_writer_ = nullptr;
  eprosima::fastdds::dds::DataWriter* stats_writer_ = nullptr;

  std::mutex wake_mutex_;
  std::condition_variable scans_ready_, queries_ready_, stats_wake_;
  std::atomic<bool> running_{true};
  std::thread ingest_thread_, stats_thread_;
  std::vector<std::thread> query_threads_;
  std::chrono::steady_clock::time_point started_;
  std::mutex stop_mutex_;
  bool stopped_ = false;
  std::atomic<bool> queries_running_{true};
  std::deque<msg::QueryRequest> query_backlog_;  // guarded by wake_mutex_
};

}  // namespace densemap::server
