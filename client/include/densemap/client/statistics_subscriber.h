// Follows the server's periodic statistics topic (densemap/statistics): `densemap-query statistics`, the
// container HEALTHCHECK and the cross-host test read a server's counters through it.
#pragma once

#include <chrono>
#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>

#include "densemap/msg/dds_node.h"
#include "densemap/msg/wire_types.h"

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
  /// The first message stamped after this call for which `done` holds; on timeout the last one (or nothing).
  std::optional<msg::ServerStatistics> waitUntil(
      const std::function<bool(const msg::ServerStatistics&)>& done, std::chrono::milliseconds timeout);
  /// The last message, if one arrived.
  std::optional<msg::ServerStatistics> last() const;

 private:
  class Listener;
  void onData(eprosima::fastdds::dds::DataReader* reader);

  msg::DdsNode& node_;
  std::unique_ptr<Listener> listener_;
  eprosima::fastdds::dds::DataReader* reader_ = nullptr;
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::optional<msg::ServerStatistics> last_;
};

}  // namespace densemap::client
