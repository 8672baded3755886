#include "densemap/client/scan_publisher.h"

#include <stdexcept>
#include <thread>

#include <fmt/format.h>
#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>

#include "densemap/client/server_join.h"
#include "densemap/msg/peer_topic.h"
#include "densemap/msg/wire_types.h"

namespace densemap::client {

namespace dds = eprosima::fastdds::dds;

class ScanPublisher::Listener : public dds::DataReaderListener {
 public:
  Listener(ScanPublisher& p, const Robot& robot) : p_(p), robot_(robot) {}
  // Attached only once the robot's progress reader is set.
  void on_data_available(dds::DataReader* r) override {
    if (r == robot_.progress_reader) {
      p_.onProgress(robot_.id, r);
    } else {
      p_.onAcks(r);
    }
  }

 private:
  ScanPublisher& p_;
  const Robot& robot_;
};

ScanPublisher::ScanPublisher(msg::DdsNode& node, const std::vector<std::string>& robot_ids) : node_(node) {
  // The robots' topics first, so that an identity refused a robot id throws before any reader exists.
  // Fast DDS 2.9 can crash (EDP::pairing_remote_writer_with_local_reader_after_security) when a secure
  // participant deletes a reader whose key exchange with a remote writer is still in flight; a statistics
  // reader made and at once deleted here was that reader (Security.ARobotReadsOnlyItsOwnAcks..., CI).
  try {
    for (const std::string& id : robot_ids) robot(id);
    statistics_ = std::make_unique<StatisticsSubscriber>(node_);
  } catch (...) {
    removeRobots();  // no destructor runs for a constructor that throws
    throw;
  }
}

std::unique_ptr<ScanPublisher::Robot> ScanPublisher::makeRobot(const std::string& robot_id) {
  if (const std::string why = msg::checkPeerId(robot_id, "robot"); !why.empty())
    throw std::invalid_argument(why + " (it names the robot's topics, densemap/scans/<robot id>)");
  auto r = std::make_unique<Robot>();
  r->id = robot_id;
  r->listener = std::make_unique<Listener>(*this, *r);
  // Each made before the next, so what throws (a permission refused) leaves nothing half made behind.
  struct Undo {
    msg::DdsNode& node;
    Robot& r;
    bool done = false;
    ~Undo() {
      if (done) return;
      if (r.ack_reader) node.remove(r.ack_reader);
      if (r.progress_reader) node.remove(r.progress_reader);
      if (r.writer) node.remove(r.writer);
    }
  } undo{node_, *r};
  auto* scans =
      node_.topic(msg::peerTopicOf(msg::kScanTopic, robot_id), msg::typeSupport<msg::ScanPubSubType>());
  r->writer = node_.writer(scans, msg::kScanWriterProfile);
  auto* progress = node_.topic(msg::peerTopicOf(msg::kRobotProgressTopic, robot_id),
                               msg::typeSupport<msg::RobotProgressPubSubType>());
  r->progress_reader = node_.reader(progress, msg::progressReaderQos(), nullptr);
  r->progress_reader->set_listener(r->listener.get());
  onProgress(robot_id, r->progress_reader);  // a sample that came before the listener
  auto* acks =
      node_.topic(msg::peerTopicOf(msg::kScanAckTopic, robot_id), msg::typeSupport<msg::ScanAckPubSubType>());
  r->ack_reader = node_.reader(acks, msg::kMessageReaderProfile, r->listener.get());
  undo.done = true;
  return r;
}

ScanPublisher::Robot& ScanPublisher::robot(const std::string& robot_id, bool* made) {
  std::lock_guard lock(robots_mutex_);
  auto it = robots_.find(robot_id);
  if (made) *made = it == robots_.end();
  if (it == robots_.end()) it = robots_.emplace(robot_id, makeRobot(robot_id)).first;
  return *it->second;
}

void ScanPublisher::onProgress(const std::string& robot_id, dds::DataReader* reader) {
  // Taken without our mutex: DDS may hold the reader's own lock while it calls the listener, and
  // makeRobot() calls this too (a sample that came before the listener), so holding ours while taking
  // would invert the two locks.
  std::optional<msg::RobotProgress> latest;
  msg::RobotProgress p;
  dds::SampleInfo info;
  while (reader->take_next_sample(&p, &info) == ReturnCode_t::RETCODE_OK) {
    if (info.valid_data) latest = p;
  }
  if (!latest) return;
  {
    std::lock_guard lock(mutex_);
    progress_[robot_id] = std::move(*latest);
  }
  changed_.notify_all();
}

std::optional<msg::RobotProgress> ScanPublisher::progress(const std::string& robot_id) const {
  std::lock_guard lock(mutex_);
  auto it = progress_.find(robot_id);
  if (it == progress_.end()) return std::nullopt;
  return it->second;
}

std::optional<msg::RobotProgress> ScanPublisher::waitForProgress(
    const std::string& robot_id, std::chrono::milliseconds timeout,
    std::optional<std::uint64_t> not_incarnation) {
  std::unique_lock lock(mutex_);
  auto fits = [&]() -> const msg::RobotProgress* {
    auto it = progress_.find(robot_id);
    if (it == progress_.end() || (not_incarnation && it->second.incarnation() == *not_incarnation))
      return nullptr;
    return &it->second;
  };
  changed_.wait_for(lock, timeout, [&] { return fits() != nullptr; });
  if (const msg::RobotProgress* p = fits()) return *p;
  return std::nullopt;
}

bool heldDurably(const msg::RobotProgress& p, const std::string& robot_id, std::uint64_t seq) {
  if (!p.journal()) return false;
  for (const auto& r : p.robots()) {
    if (r.robot_id() != robot_id) continue;
    const auto& iv = r.intervals();
    for (std::size_t i = 0; i + 1 < iv.size(); i += 2)
      if (iv[i] <= seq && seq <= iv[i + 1]) return true;
  }
  return false;
}

std::optional<std::uint64_t> lastDurableSeq(const msg::RobotProgress& p, const std::string& robot_id) {
  for (const auto& r : p.robots()) {
    if (r.robot_id() == robot_id && r.durable_scans() > 0) return r.last_durable_sequence();
  }
  return std::nullopt;
}

ScanPublisher::~ScanPublisher() {
  statistics_.reset();
  removeRobots();
}

void ScanPublisher::removeRobots() {
  // Stop callbacks before the listeners go away.
  std::lock_guard lock(robots_mutex_);
  for (auto& [id, r] : robots_) {
    node_.remove(r->ack_reader);
    node_.remove(r->progress_reader);
    node_.remove(r->writer);
  }
  robots_.clear();
}

bool ScanPublisher::waitForServer(std::chrono::milliseconds timeout) {
  // Matching is not symmetric: the server's reader may not know our writer yet when ours knows it, and a
  // scan sent then would be lost. A statistics message from the server shows it has discovered us (or,
  // with statistics switched off, a grace period after matching does).
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  auto all_matched = [this] {
    std::lock_guard lock(robots_mutex_);
    for (auto& [id, r] : robots_)
      if (!msg::matchedBothWays(*r->writer, *r->ack_reader)) return false;
    return true;
  };
  while (std::chrono::steady_clock::now() < deadline) {
    if (all_matched()) {
      if (!matched_at_) matched_at_ = std::chrono::steady_clock::now();
      if (lastStatistics() ||
          std::chrono::steady_clock::now() - *matched_at_ > std::chrono::milliseconds(2500)) {
        return true;
      }
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return false;
}

std::string ScanPublisher::joinState() {
  std::string out;
  {
    std::lock_guard lock(robots_mutex_);
    for (auto& [id, r] : robots_) {
      eprosima::fastdds::dds::PublicationMatchedStatus pub;
      eprosima::fastdds::dds::SubscriptionMatchedStatus sub;
      r->writer->get_publication_matched_status(pub);
      r->ack_reader->get_subscription_matched_status(sub);
      out += fmt::format("{}{}: scans read by {} server reader(s), acknowledgements from {} server writer(s)",
                         out.empty() ? "" : "; ", id, pub.current_count, sub.current_count);
    }
  }
  out += lastStatistics() ? "; statistics from a server seen" : "; no statistics from a server yet";
  if (node_.secure()) {
    out += kUnauthenticatedHint;
  }
  return out;
}

msg::Scan toMessage(const std::string& robot_id, std::uint64_t seq, const io::Scan& scan) {
  msg::Scan m;
  m.robot_id(robot_id);
  m.seq(seq);
  m.stamp_ns(msg::nowNs());
  m.frame_id(scan.frame == io::PointFrame::kWorld ? "world" : "sensor");
  const Eigen::Vector3d t = scan.pose.translation();
  const auto q = io::quaternionOf(scan.pose);
  m.sensor_pose().px(t.x());
  m.sensor_pose().py(t.y());
  m.sensor_pose().pz(t.z());
  m.sensor_pose().qw(q[0]);
  m.sensor_pose().qx(q[1]);
  m.sensor_pose().qy(q[2]);
  m.sensor_pose().qz(q[3]);
  auto& xyz = m.points();
  xyz.resize(scan.points.size() * 3);
  for (std::size_t i = 0; i < scan.points.size(); ++i) {
    xyz[3 * i] = scan.points[i].x();
    xyz[3 * i + 1] = scan.points[i].y();
    xyz[3 * i + 2] = scan.points[i].z();
  }
  if (scan.lidar) {
    msg::LidarGeometry g;
    g.rows(static_cast<std::uint16_t>(scan.lidar->rows));
    g.columns(static_cast<std::uint16_t>(scan.lidar->columns));
    g.fov_up_deg(scan.lidar->fov_up_deg);
    g.fov_down_deg(scan.lidar->fov_down_deg);
    g.fov_horizontal_deg(scan.lidar->fov_horizontal_deg);
    m.lidar(g);
  }
  return m;
}

bool ScanPublisher::publish(const std::string& robot_id, std::uint64_t seq, const io::Scan& scan) {
  msg::Scan m = toMessage(robot_id, seq, scan);
  return publishRaw(m);
}

bool ScanPublisher::publishRaw(msg::Scan& m, const std::string& as_robot) {
  bool made = false;
  Robot& r = robot(as_robot.empty() ? m.robot_id() : as_robot, &made);
  if (made) {
    // A sample written before the server's reader matched is lost (volatile): wait for it, bounded.
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (!msg::matchedBothWays(*r.writer, *r.ack_reader) && std::chrono::steady_clock::now() < deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  m.publish_ns(msg::nowNs());
  return r.writer->write(&m);
}

void ScanPublisher::onAcks(dds::DataReader* reader) {
  msg::ScanAck a;
  dds::SampleInfo info;
  std::lock_guard lock(mutex_);
  while (reader->take_next_sample(&a, &info) == ReturnCode_t::RETCODE_OK) {
    if (!info.valid_data) continue;
    // A resend's acknowledgement (a duplicate) does not replace the first one, unless that was not durable.
    auto [it, fresh] = acks_.try_emplace({a.robot_id(), a.seq()}, a);
    if (!fresh && !it->second.durable() && a.durable()) it->second = a;
    if (ack_observer_) ack_observer_(a);
  }
  changed_.notify_all();
}

void ScanPublisher::setAckObserver(std::function<void(const msg::ScanAck&)> observer) {
  std::lock_guard lock(mutex_);
  ack_observer_ = std::move(observer);
}

AckCounts ScanPublisher::acks(const std::set<std::string>& robots) const {
  std::lock_guard lock(mutex_);
  AckCounts c;
  for (const auto& [key, a] : acks_) {
    if (!robots.count(key.first)) continue;
    if (a.outcome() == msg::SCAN_APPLIED) ++c.applied;
    if (a.outcome() == msg::SCAN_REJECTED) ++c.rejected;
    if (a.outcome() == msg::SCAN_DROPPED) ++c.dropped;
    if (a.outcome() == msg::SCAN_DUPLICATE) ++c.duplicate;
    if (a.durable()) ++c.durable;
  }
  return c;
}

AckCounts ScanPublisher::waitForAcks(const std::set<std::string>& robots, std::uint64_t expected,
                                     std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    AckCounts c = acks(robots);
    if (c.total() >= expected || std::chrono::steady_clock::now() >= deadline) return c;
    std::unique_lock lock(mutex_);
    changed_.wait_for(lock, std::chrono::milliseconds(50));
  }
}

std::optional<msg::ScanAck> ScanPublisher::ack(const std::string& robot_id, std::uint64_t seq) const {
  std::lock_guard lock(mutex_);
  auto it = acks_.find({robot_id, seq});
  if (it == acks_.end()) return std::nullopt;
  return it->second;
}

std::vector<double> ScanPublisher::latenciesMs(const std::set<std::string>& robots) const {
  std::lock_guard lock(mutex_);
  std::vector<double> out;
  for (const auto& [key, a] : acks_) {
    if (robots.count(key.first) && a.outcome() == msg::SCAN_APPLIED) {
      out.push_back(static_cast<double>(a.done_ns() - a.publish_ns()) * 1e-6);
    }
  }
  return out;
}

std::optional<msg::ServerStatistics> ScanPublisher::lastStatistics() const { return statistics_->last(); }

std::optional<msg::ServerStatistics> ScanPublisher::waitForStatistics(const std::set<std::string>& robots,
                                                                      std::uint64_t expected,
                                                                      std::chrono::milliseconds timeout) {
  return statistics_->waitUntil(
      [&](const msg::ServerStatistics& s) {
        const RobotTotals t = totalsFor(s, robots);
        return t.processed + t.dropped + t.rejected >= expected;
      },
      timeout);
}

RobotTotals totalsFor(const msg::ServerStatistics& s, const std::set<std::string>& robots) {
  RobotTotals t;
  for (const auto& r : s.robots()) {
    if (!robots.count(r.robot_id())) continue;
    t.received += r.received();
    t.processed += r.processed();
    t.dropped += r.dropped();
    t.rejected += r.rejected();
  }
  return t;
}

}  // namespace densemap::client
