// A ROS 2 node as the tests play it: raw-CDR readers and writers on ROS 2's DDS names and QoS, the way
// rmw_fastrtps creates them, and a densemap service with only its ROS 2 edge in this process.
#pragma once

#include <chrono>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <fastdds/dds/subscriber/SampleInfo.hpp>

#include "densemap/msg/raw_cdr_type.h"
#include "densemap/msg/ros2_qos.h"
#include "densemap/ros2/names.h"
#include "densemap/ros2/qos.h"
#include "densemap/server/map_service.h"
#include "densemap/server/ros2_edge/ros2_edge.h"

namespace densemap::test {

namespace fdds = eprosima::fastdds::dds;

/// densemap-server --ros2-only in this process.
struct Ros2Server {
  Ros2Server(const server::ServiceOptions& service_options, const server::ros2_edge::Ros2EdgeOptions& ros2,
             int domain)
      : service(service_options), edge(service, ros2, dds(domain)) {}
  static msg::DdsOptions dds(int domain) {
    msg::DdsOptions d;
    d.domain = domain;
    d.loopback = true;
    return d;
  }
  /// Waits until the edge has matched a cloud publisher and a TF (or pose) publisher: a publisher's own
  /// match comes first, and what it sends before the edge's reader matches it is lost.
  bool waitForPublishers(std::chrono::seconds timeout = std::chrono::seconds(10)) {
    const auto until = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < until) {
      if (edge.matchedCloudPublishers() > 0 && edge.matchedPosePublishers() > 0) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return false;
  }
  /// Waits until `n` clouds are in the map (or `timeout`); true when they are.
  bool waitForMapped(std::uint64_t n, std::chrono::seconds timeout = std::chrono::seconds(60)) {
    const auto until = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < until) {
      if (service.statistics().totals().processed >= n) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return false;
  }
  server::MapService service;
  server::ros2_edge::Ros2Edge edge;
};

/// A test's ROS 2 participant.
struct Ros2TestNode {
  explicit Ros2TestNode(int domain, const std::string& name = "test_node") : node(options(domain, name)) {}
  static msg::DdsOptions options(int domain, const std::string& name) {
    msg::DdsOptions d = Ros2Server::dds(domain);
    d.name = name;
    return d;
  }
  fdds::DataWriter* writer(const std::string& dds_topic, const std::string& dds_type, const ros2::Qos& qos) {
    return node.writer(node.topic(dds_topic, msg::rawCdrType(dds_type)), msg::writerQos(qos));
  }
  fdds::DataReader* reader(const std::string& dds_topic, const std::string& dds_type, const ros2::Qos& qos) {
    return node.reader(node.topic(dds_topic, msg::rawCdrType(dds_type)), msg::readerQos(qos), nullptr);
  }
  fdds::DataWriter* publisher(const std::string& ros_topic, const char* ros_type, const ros2::Qos& qos) {
    return writer(ros2::topicOnDds(ros_topic), ros2::typeOnDds(ros_type), qos);
  }
  fdds::DataReader* subscriber(const std::string& ros_topic, const char* ros_type, const ros2::Qos& qos) {
    return reader(ros2::topicOnDds(ros_topic), ros2::typeOnDds(ros_type), qos);
  }
  static bool write(fdds::DataWriter* w, std::vector<std::uint8_t> bytes) {
    msg::RawSample s{std::move(bytes)};
    return w->write(&s);
  }
  /// The next sample within `timeout` (its info in `info` when given).
  static std::optional<std::vector<std::uint8_t>> take(fdds::DataReader* r, std::chrono::milliseconds timeout,
                                                       fdds::SampleInfo* info = nullptr) {
    const auto until = std::chrono::steady_clock::now() + timeout;
    msg::RawSample s;
    fdds::SampleInfo i;
    while (std::chrono::steady_clock::now() < until) {
      if (r->take_next_sample(&s, &i) == ReturnCode_t::RETCODE_OK && i.valid_data) {
        if (info) *info = i;
        return std::move(s.bytes);
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return std::nullopt;
  }
  /// Until `entity` (a writer or a reader) has matched a peer, or `timeout`.
  template <class Entity>
  static bool waitMatched(Entity* entity,
                          std::chrono::milliseconds timeout = std::chrono::milliseconds(10000)) {
    const auto until = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < until) {
      if (matchedCount(entity) > 0) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return false;
  }
  static int matchedCount(fdds::DataWriter* w) {
    fdds::PublicationMatchedStatus s;
    w->get_publication_matched_status(s);
    return s.current_count;
  }
  static int matchedCount(fdds::DataReader* r) {
    fdds::SubscriptionMatchedStatus s;
    r->get_subscription_matched_status(s);
    return s.current_count;
  }
  msg::DdsNode node;
};

}  // namespace densemap::test
