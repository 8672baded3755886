// Request-reply over DDS: sends QueryRequests with this client's id and waits for the matching reply.
// Replies for other clients are skipped by their client_id. Safe to call from several threads at once.
#pragma once

#include <chrono>
#include <cstdint>
#include <future>
#include <map>
#include <mutex>
#include <stdexcept>
#include <string>

#include "densemap/msg/dds_node.h"
#include "densemap/msg/densemap.h"

namespace densemap::client {

class QueryTimeout : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class QueryClient {
 public:
  QueryClient(msg::DdsNode& node, std::string client_id);
  ~QueryClient();
  QueryClient(const QueryClient&) = delete;
  QueryClient& operator=(const QueryClient&) = delete;

  /// Waits until a server's request reader and reply writer are matched; false on timeout.
  bool waitForServer(std::chrono::milliseconds timeout);

  /// Sends the request (client_id and request_id are filled in) and returns the reply. Throws QueryTimeout.
  msg::QueryReply call(msg::QueryRequest request,
                       std::chrono::milliseconds timeout = std::chrono::seconds(10));

  const std::string& id() const { return id_; }

 private:
  class Listener;
  void onReplies(eprosima::fastdds::dds::DataReader* reader);

  msg::DdsNode& node_;
  std::string id_;
  std::unique_ptr<Listener> listener_;
  eprosima::fastdds::dds::DataWriter* writer_ = nullptr;
  eprosima::fastdds::dds::DataReader* reader_ = nullptr;
  std::mutex mutex_;
  std::uint64_t next_id_ = 1;
  std::map<std::uint64_t, std::promise<msg::QueryReply>> pending_;
};

/// A request with the box fields set.
msg::QueryRequest boxRequest(msg::QueryKind kind, const std::array<float, 3>& lo,
                             const std::array<float, 3>& hi);

std::string toString(msg::QueryStatus s);
std::string toString(msg::ScanOutcome o);

}  // namespace densemap::client
