// Follows the server's periodic statistics topic (densemap/statistics): `densemap-query statistics`, the
// container HEALTHCHECK and the cross-host test read a server's counters through it.
#pragma once

#include <chrono>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <optional>

#include "densemap/msg/dds_node.h"
#include "densemap/msg/densemap.h"

namespace densemap::client {

class StatisticsSubscriber {
 public:
  explicit StatisticsSubscriber(msg::DdsNode& node);
  ~StatisticsSubscriber();
  StatisticsSubscriber(const StatisticsSubscriber&) = delete;
  StatisticsSubscriber& operator=(const StatisticsSubscriber&) = delete;

  /// The first statistics message stamped after this call, or nothing when none arrives in time (no server,
  /// or one with --statistics-period 0).
  std::optional<msg::ServerStatistics> waitForNext(std::chrono::milliseconds timeout);

 private:
  class Listener;
  void onData(eprosima::fastdds::dds::DataReader* reader);

  msg::DdsNode& node_;
  std::unique_ptr<Listener> listener_;
  eprosima::fastdds::dds::DataReader* reader_ = nullptr;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::optional<msg::ServerStatistics> last_;
};

}  // namespace densemap::client
