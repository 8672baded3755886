#include "densemap/client/ros2_player.h"

#include <algorithm>
#include <chrono>
#include <map>
#include <thread>

#include <spdlog/spdlog.h>

#include "densemap/cli/cli_common.h"
#include "densemap/msg/raw_cdr_type.h"
#include "densemap/msg/ros2_qos.h"
#include "densemap/ros2/message_codec.h"
#include "densemap/ros2/names.h"
#include "densemap/ros2/qos.h"
#include "densemap/ros2/scan_messages.h"
#include "densemap/ros2/sensor_pose.h"

namespace densemap::client {

namespace fdds = eprosima::fastdds::dds;
using Clock = std::chrono::steady_clock;

namespace {

int subscribers(fdds::DataWriter* w) {
  fdds::PublicationMatchedStatus s;
  w->get_publication_matched_status(s);
  return s.current_count;
}

/// Waits for a subscriber to `w`'s topic, saying what it waits for after 1 s and every 10 s after.
bool waitForReader(fdds::DataWriter* w, const Ros2PlayOptions& options) {
  const auto start = Clock::now();
  const auto until = start + std::chrono::duration<double>(options.wait_s);
  auto report = start + std::chrono::seconds(1);
  while (Clock::now() < until) {
    if (subscribers(w) > 0) {
      // Matching is not symmetric: the reader matches this writer a moment after this writer matched it,
      // and a best-effort sample sent in between is lost. A subscriber's side is not visible from here, so
      // give it a moment (ros2 bag play's --delay plays the same role).
      std::this_thread::sleep_for(std::chrono::milliseconds(250));
      return true;
    }
    if (Clock::now() >= report) {
      spdlog::warn("{} for a subscriber to {} ({:.0f} s of {:g} s) on {}",
                   report == start + std::chrono::seconds(1) ? "waiting" : "still waiting",
                   w->get_topic()->get_name(), std::chrono::duration<double>(Clock::now() - start).count(),
                   options.wait_s, options.where);
      report = Clock::now() + std::chrono::seconds(10);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return false;
}

/// One line every 10 s while playing (a ROS 2 player gets no acknowledgements: it says whether a
/// subscriber is matched).
class PlayReport {
 public:
  explicit PlayReport(fdds::DataWriter* clouds) : clouds_(clouds), next_(Clock::now() + kEvery) {}
  void tick(std::size_t sent, std::size_t total, const char* what) {
    if (Clock::now() < next_) return;
    next_ = Clock::now() + kEvery;
    spdlog::info("published {} of {} {}; {} subscriber(s) matched on {}", sent, total, what,
                 clouds_ ? subscribers(clouds_) : 0, clouds_ ? clouds_->get_topic()->get_name() : "");
  }

 private:
  static constexpr std::chrono::seconds kEvery{10};
  fdds::DataWriter* clouds_;
  Clock::time_point next_;
};

void finish(const std::vector<fdds::DataWriter*>& writers, double wait_s) {
  for (auto* w : writers) w->wait_for_acknowledgments(eprosima::fastrtps::Duration_t(wait_s));
  // Best-effort samples have no acknowledgement: give the last ones time to leave the asynchronous writer.
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
}

}  // namespace

Ros2PlayResult playBag(const ros2::BagReader& bag, msg::DdsNode& node, const Ros2PlayOptions& options) {
  std::vector<fdds::DataWriter*> writers(bag.topics().size(), nullptr);
  std::vector<fdds::DataWriter*> cloud_writers;
  for (std::size_t i = 0; i < bag.topics().size(); ++i) {
    const ros2::BagTopic& t = bag.topics()[i];
    if (t.serialization_format != "cdr") {
      spdlog::warn("{}: serialization '{}' is not cdr; not played", t.name, t.serialization_format);
      continue;
    }
    ros2::Qos qos = ros2::Qos::reliableDefault();
    try {
      if (auto recorded = ros2::parseOfferedQos(t.offered_qos_profiles)) qos = *recorded;
    } catch (const std::invalid_argument& e) {
      spdlog::warn("{}: {}; playing with the default QoS", t.name, e.what());
    }
    auto* topic = node.topic(ros2::topicOnDds(t.name), msg::rawCdrType(ros2::typeOnDds(t.type)));
    writers[i] = node.writer(topic, msg::writerQos(qos));
    if (t.type == ros2::kPointCloud2Type) cloud_writers.push_back(writers[i]);
    spdlog::info("playing {} ({}) {} {} depth {}", t.name, t.type, qos.reliable ? "reliable" : "best effort",
                 qos.transient_local ? "transient local" : "volatile", qos.depth);
  }
  Ros2PlayResult r;
  for (auto* w : cloud_writers) {
    if (waitForReader(w, options)) continue;
    r.unread_topic = w->get_topic()->get_name();
    return r;  // nobody reads the clouds: the caller says why that may be
  }
  const auto& messages = bag.messages();
  if (messages.empty()) return r;
  PlayReport report(cloud_writers.empty() ? nullptr : cloud_writers.front());
  const auto start = Clock::now();
  r.first_sent = start;
  const std::int64_t t0 = messages.front().log_time_ns;
  cli::Progress progress("playing", messages.size());
  for (const auto& m : messages) {
    fdds::DataWriter* w = writers[m.topic];
    if (!w) continue;
    if (!options.as_fast_as_possible) {
      const auto due = start + std::chrono::nanoseconds(static_cast<std::int64_t>(
                                   static_cast<double>(m.log_time_ns - t0) / options.speed));
      std::this_thread::sleep_until(due);
    }
    msg::RawSample s{bag.readMessage(m)};
    if (!w->write(&s)) spdlog::warn("could not publish on {}", w->get_topic()->get_name());
    ++r.messages;
    if (bag.topics()[m.topic].type == ros2::kPointCloud2Type) ++r.clouds;
    progress.step(r.messages);
    report.tick(r.messages, messages.size(), "messages");
  }
  std::vector<fdds::DataWriter*> all;
  for (auto* w : writers)
    if (w) all.push_back(w);
  finish(all, options.wait_s);
  r.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return r;
}

Ros2PlayResult playScans(const std::vector<io::Scan>& scans, msg::DdsNode& node,
                         const Ros2PlayOptions& options) {
  auto* clouds = node.topic(ros2::topicOnDds(ros2::resolveName(options.cloud_topic, "densemap_replay")),
                            msg::rawCdrType(ros2::typeOnDds(ros2::kPointCloud2Type)));
  auto* tf =
      node.topic(ros2::topicOnDds(ros2::kTfTopic), msg::rawCdrType(ros2::typeOnDds(ros2::kTfMessageType)));
  // A LiDAR driver's sensor-data QoS, and tf2's broadcaster QoS.
  fdds::DataWriter* cloud_writer = node.writer(clouds, msg::writerQos(ros2::Qos::sensorData()));
  fdds::DataWriter* tf_writer = node.writer(tf, msg::writerQos(ros2::Qos::tf()));
  Ros2PlayResult r;
  if (!waitForReader(cloud_writer, options)) {
    r.unread_topic = cloud_writer->get_topic()->get_name();
    return r;
  }
  waitForReader(tf_writer, options);
  PlayReport report(cloud_writer);
  const auto start = Clock::now();
  r.first_sent = start;
  const auto period = std::chrono::duration<double>(options.rate > 0 ? 1.0 / options.rate : 0.0);
  cli::Progress progress("publishing", scans.size());
  for (std::size_t i = 0; i < scans.size(); ++i) {
    std::this_thread::sleep_until(
        start + std::chrono::duration_cast<Clock::duration>(period * static_cast<double>(i)));
    const std::int64_t stamp = msg::nowNs();
    const ros2::ScanMessages m =
        ros2::scanMessages(scans[i], stamp, options.fixed_frame, options.sensor_frame);
    // The transform first, as a well-behaved robot sends it (a cloud before its TF waits at the server).
    msg::RawSample t{m.transform}, c{m.cloud};
    tf_writer->write(&t);
    cloud_writer->write(&c);
    r.messages += 2;
    ++r.clouds;
    progress.step(i + 1);
    report.tick(r.clouds, scans.size(), "clouds");
  }
  finish({tf_writer, cloud_writer}, options.wait_s);
  r.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return r;
}

}  // namespace densemap::client
