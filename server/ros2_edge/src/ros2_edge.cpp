#include "densemap/server/ros2_edge/ros2_edge.h"

#include <pthread.h>

#include <array>
#include <map>

#include <fastdds/rtps/common/WriteParams.h>
#include <spdlog/spdlog.h>
#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>

#include <fastdds/dds/domain/DomainParticipantListener.hpp>

#include "densemap/msg/checked_type.h"
#include "densemap/msg/raw_cdr_type.h"
#include "densemap/msg/ros2_qos.h"
#include "densemap/ros2/discovery_info.h"
#include "densemap/ros2/message_codec.h"
#include "densemap/ros2/names.h"
#include "densemap/ros2/qos.h"
#include "densemap/ros2/service_framing.h"
#include "densemap/server/ros2_edge/matched_readers.h"
#include "densemap/server/ros2_edge/ros2_options.h"

namespace densemap::server::ros2_edge {

namespace fdds = eprosima::fastdds::dds;
using Clock = std::chrono::steady_clock;

/// How long a reply waits for its client's reader to be matched (MatchedReaders says why). Services are
/// rare and off the scan path; the bound keeps a client that vanished from holding the others up long.
constexpr std::chrono::milliseconds kReplyReaderWait{1000};

/// One ROS 2 service as rmw_fastrtps carries it: requests on rq/<name>Request, replies on rr/<name>Reply
/// matched to their request by the sample identity.
struct Ros2Edge::Service {
  enum class Kind { kClearBox, kReset, kGetBinary, kGetFull };
  Kind kind;
  std::string name;
  fdds::DataReader* requests = nullptr;
  fdds::DataWriter* replies = nullptr;
  MatchedReaders reply_readers;  ///< the clients' reply readers `replies` has matched
};

class Ros2Edge::Listener : public fdds::DataReaderListener {
 public:
  explicit Listener(Ros2Edge& e) : e_(e) {}
  void on_data_available(fdds::DataReader* reader) override {
    if (reader == e_.tf_reader_) {
      e_.takeTf(reader, false);
    } else if (reader == e_.tf_static_reader_) {
      e_.takeTf(reader, true);
    } else if (reader == e_.pose_reader_) {
      e_.takePoses();
    } else {
      e_.wake_.notify_all();  // clouds and service requests: their threads take them
    }
  }

 private:
  Ros2Edge& e_;
};

// The DDS vendor of every remote participant, from RTPS participant discovery, so a service request can be
// read in its requester's framing. Fast DDS 2.9 gives no matched writer's participant data through the
// reader (get_matched_publication_data is not supported), but a writer's GUID prefix is its participant's,
// and discovery comes before any of its samples.
class Ros2Edge::VendorListener : public fdds::DomainParticipantListener {
 public:
  void on_participant_discovery(fdds::DomainParticipant*,
                                eprosima::fastrtps::rtps::ParticipantDiscoveryInfo&& info) override {
    using Status = eprosima::fastrtps::rtps::ParticipantDiscoveryInfo::DISCOVERY_STATUS;
    const auto& prefix = info.info.m_guid.guidPrefix;
    std::lock_guard lock(mutex_);
    if (info.status == Status::REMOVED_PARTICIPANT || info.status == Status::DROPPED_PARTICIPANT) {
      vendors_.erase(prefix);
    } else if (vendors_.size() < kMaxParticipants || vendors_.count(prefix)) {
      vendors_[prefix] = {info.info.m_VendorId[0], info.info.m_VendorId[1]};
    }
  }
  /// The vendor of the participant whose prefix `writer` has; {0, 0} (unknown) when not discovered.
  std::array<std::uint8_t, 2> vendorOf(const eprosima::fastrtps::rtps::GUID_t& writer) const {
    std::lock_guard lock(mutex_);
    const auto it = vendors_.find(writer.guidPrefix);
    return it == vendors_.end() ? std::array<std::uint8_t, 2>{0, 0} : it->second;
  }

 private:
  static constexpr std::size_t kMaxParticipants = 65536;  // bounded against a flood of fake participants
  mutable std::mutex mutex_;
  std::map<eprosima::fastrtps::rtps::GuidPrefix_t, std::array<std::uint8_t, 2>> vendors_;
};

namespace {

ros2::Guid guidBytes(const eprosima::fastrtps::rtps::GUID_t& guid) {
  ros2::Guid out{};
  std::copy(std::begin(guid.guidPrefix.value), std::end(guid.guidPrefix.value), out.begin());
  std::copy(std::begin(guid.entityId.value), std::end(guid.entityId.value), out.begin() + 12);
  return out;
}

/// Takes every sample of `reader`; calls f(bytes, info) for each with data.
template <class F>
void takeAll(fdds::DataReader* reader, F&& f) {
  msg::RawSample sample;
  fdds::SampleInfo info;
  while (reader->take_next_sample(&sample, &info) == ReturnCode_t::RETCODE_OK)
    if (info.valid_data) f(sample.bytes, info);
}

std::int64_t toNs(const eprosima::fastrtps::rtps::Time_t& t) {
  return static_cast<std::int64_t>(t.seconds()) * 1'000'000'000 + t.nanosec();
}

}  // namespace

Ros2Edge::Ros2Edge(MapService& service, const Ros2EdgeOptions& options, const msg::DdsOptions& dds)
    : service_(service), options_(options) {
  {
    Ros2EdgeOptions copy = options_;  // ranges and choices live in the option table only
    if (const std::string why = ros2Options(copy).validate(); !why.empty()) throw std::invalid_argument(why);
  }
  const std::string& node = options_.node_name;
  auto resolve = [&](const std::string& name) {
    try {
      return ros2::resolveName(name, node);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(std::string(e.what()) +
                                  " (check --cloud-topic, --pose-topic and --node-name)");
    }
  };
  listener_ = std::make_unique<Listener>(*this);
  msg::DdsOptions d = dds;
  d.name = node;           // what DDS tools show; ROS 2 tools list nodes from ros_discovery_info
  d.topic_namespace = "";  // ROS 2 names are resolved by ROS 2's rules, not densemap's namespace
  if (!options_.security_dir.empty()) d.security_dir = options_.security_dir;
  vendors_ = std::make_unique<VendorListener>();
  node_ = std::make_unique<msg::DdsNode>(d, vendors_.get());
  auto topic = [&](const std::string& ros_name, const char* ros_type) {
    return node_->topic(ros2::topicOnDds(resolve(ros_name)), msg::rawCdrType(ros2::typeOnDds(ros_type)));
  };
  // Clouds: a best-effort reader matches sensor-data (best effort) and reliable publishers alike.
  // Its history is ours to size (depth does not take part in matching): room for a burst between two
  // takes by the intake thread, which moves clouds to its own TF queue at once.
  ros2::Qos cloud_qos = ros2::Qos::sensorData();
  cloud_qos.depth = 32;
  cloud_reader_ = node_->reader(topic(options_.frames.cloud_topic, ros2::kPointCloud2Type),
                                msg::readerQos(cloud_qos), nullptr);
  if (options_.frames.pose_topic.empty()) {
    tf_reader_ =
        node_->reader(topic(ros2::kTfTopic, ros2::kTfMessageType), msg::readerQos(ros2::Qos::tf()), nullptr);
    ros2::Qos static_qos = ros2::Qos::tfStatic();
    static_qos.depth = 100;  // one latched sample from each static broadcaster
    tf_static_reader_ =
        node_->reader(topic(ros2::kTfStaticTopic, ros2::kTfMessageType), msg::readerQos(static_qos), nullptr);
  } else {
    pose_type_ = options_.pose_type == "odometry" ? ros2::kOdometryType : ros2::kPoseStampedType;
    pose_reader_ = node_->reader(topic(options_.frames.pose_topic, pose_type_.c_str()),
                                 msg::readerQos(ros2::Qos::sensorData()), nullptr);
  }
  const ros2::Qos map_ros_qos = options_.latch ? ros2::Qos::latched() : ros2::Qos{true, false, false, 5};
  eprosima::fastdds::dds::DataWriterQos map_qos = msg::writerQos(map_ros_qos);
  // Written from the edge's own publishing thread, so synchronous costs the scans nothing: with Fast DDS
  // 2.9's asynchronous writers a Cyclone DDS subscriber (rmw_cyclonedds) now and then never received a
  // cycle's last map, in CycloneDds.ARos2NodeOnCycloneIsMappedAndReadsEveryOutputAsDensemapsOwn under load
  // (2 failures in 3 runs; 0 in 4 synchronous).
  map_qos.publish_mode().kind = fdds::SYNCHRONOUS_PUBLISH_MODE;
  binary_writer_ = node_->writer(topic("octomap_binary", ros2::kOctomapType), map_qos);
  full_writer_ = node_->writer(topic("octomap_full", ros2::kOctomapType), map_qos);
  projected_writer_ = node_->writer(topic("projected_map", ros2::kOccupancyGridType), map_qos);
  centres_writer_ = node_->writer(topic("octomap_point_cloud_centers", ros2::kPointCloud2Type), map_qos);

  const struct {
    Service::Kind kind;
    const char* name;
    const char* type;
  } services[] = {{Service::Kind::kClearBox, "~/clear_bbox", "octomap_msgs/srv/BoundingBoxQuery"},
                  {Service::Kind::kReset, "~/reset", "std_srvs/srv/Empty"},
                  {Service::Kind::kGetBinary, "octomap_binary", "octomap_msgs/srv/GetOctomap"},
                  {Service::Kind::kGetFull, "octomap_full", "octomap_msgs/srv/GetOctomap"}};
  for (const auto& s : services) {
    auto svc = std::make_unique<Service>();
    svc->kind = s.kind;
    svc->name = resolve(s.name);
    auto* rq =
        node_->topic(ros2::requestTopicOnDds(svc->name), msg::rawCdrType(ros2::requestTypeOnDds(s.type)));
    auto* rr =
        node_->topic(ros2::replyTopicOnDds(svc->name), msg::rawCdrType(ros2::responseTypeOnDds(s.type)));
    svc->requests = node_->reader(rq, msg::readerQos(ros2::Qos::reliableDefault()), nullptr);
    svc->replies = node_->writer(rr, msg::writerQos(ros2::Qos::reliableDefault()), &svc->reply_readers);
    services_.push_back(std::move(svc));
  }
  publishDiscoveryInfo();
  // Listeners last: every reader is known when the first callback comes.
  for (auto* r : {cloud_reader_, tf_reader_, tf_static_reader_, pose_reader_})
    if (r) r->set_listener(listener_.get());
  for (auto& s : services_) s->requests->set_listener(listener_.get());

  intake_thread_ = std::thread([this] {
    pthread_setname_np(pthread_self(), "dm-ros2-clouds");
    intakeLoop();
  });
  publish_thread_ = std::thread([this] {
    pthread_setname_np(pthread_self(), "dm-ros2-maps");
    publishLoop();
  });
  service_thread_ = std::thread([this] {
    pthread_setname_np(pthread_self(), "dm-ros2-srv");
    serviceLoop();
  });
  // Static transforms and requests that arrived before the listeners were attached.
  if (tf_static_reader_) takeTf(tf_static_reader_, true);
  if (tf_reader_) takeTf(tf_reader_, false);
  spdlog::info(
      "ROS 2 edge on domain {}: node /{}, clouds on {} placed in '{}' through {}; maps on octomap_binary, "
      "octomap_full, projected_map, octomap_point_cloud_centers ({}); services {}/clear_bbox, "
      "{}/reset, octomap_binary, octomap_full",
      dds.domain, node, resolve(options_.frames.cloud_topic), options_.frames.fixed_frame,
      options_.frames.pose_topic.empty() ? std::string("/tf and /tf_static")
                                         : resolve(options_.frames.pose_topic) + " (" + pose_type_ + ")",
      options_.latch ? "latched" : "volatile", "/" + node, "/" + node);
  msg::logSecurity(*node_, "ROS 2 edge");
}

Ros2Edge::~Ros2Edge() { stop(); }

void Ros2Edge::stop() {
  std::lock_guard stop_lock(stop_mutex_);
  if (stopped_) return;
  stopped_ = true;
  running_ = false;
  wake_.notify_all();
  for (auto* t : {&intake_thread_, &publish_thread_, &service_thread_})
    if (t->joinable()) t->join();
  node_->close();
  const Ros2Counters c = counters();
  spdlog::info(
      "ROS 2 edge stopped: {} clouds received, {} mapped, {} undecodable, {} waited out for TF, {} pushed "
      "out "
      "of the TF queue ({} still waiting), {} transforms refused, {} service requests ({} replied before the "
      "client's reader was matched), {} maps published",
      c.clouds_received, c.clouds_submitted, c.clouds_undecodable, c.clouds_waited_out,
      c.clouds_queue_dropped, pending_.size(), c.tf_refused, c.service_requests, c.replies_unmatched,
      c.maps_published);
}

Ros2Counters Ros2Edge::counters() const {
  std::lock_guard lock(mutex_);
  Ros2Counters c = counters_;
  c.tf_wait_ms = tf_wait_.summary();
  return c;
}

namespace {
std::size_t matched(fdds::DataReader* r) {
  if (!r) return 0;
  fdds::SubscriptionMatchedStatus s;
  r->get_subscription_matched_status(s);
  return static_cast<std::size_t>(s.current_count);
}
}  // namespace

std::size_t Ros2Edge::matchedCloudPublishers() const { return matched(cloud_reader_); }
std::size_t Ros2Edge::matchedPosePublishers() const { return matched(tf_reader_) + matched(pose_reader_); }

std::size_t Ros2Edge::matchedMapSubscribers() const {
  std::size_t fewest = std::numeric_limits<std::size_t>::max();
  for (fdds::DataWriter* w : {binary_writer_, full_writer_, projected_writer_, centres_writer_}) {
    fdds::PublicationMatchedStatus s;
    w->get_publication_matched_status(s);
    fewest = std::min(fewest, static_cast<std::size_t>(s.current_count));
  }
  return fewest;
}

void Ros2Edge::takeTf(fdds::DataReader* reader, bool is_static) {
  std::uint64_t refused = 0, undecodable = 0;
  {
    std::lock_guard lock(tf_mutex_);
    takeAll(reader, [&](const std::vector<std::uint8_t>& bytes, const fdds::SampleInfo&) {
      try {
        for (const std::string& why : ros2::addTfMessage(tf_, bytes, is_static)) {
          ++refused;
          spdlog::warn("{}: {}", is_static ? "/tf_static" : "/tf", why);
        }
      } catch (const ros2::DecodeError& e) {
        ++undecodable;
        spdlog::warn("{}: undecodable TFMessage: {}", is_static ? "/tf_static" : "/tf", e.what());
      }
    });
  }
  {
    std::lock_guard lock(mutex_);
    counters_.tf_refused += refused;
    counters_.tf_undecodable += undecodable;
  }
  wake_.notify_all();  // waiting clouds may be placed now
}

void Ros2Edge::takePoses() {
  std::uint64_t refused = 0, undecodable = 0;
  {
    std::lock_guard lock(tf_mutex_);
    takeAll(pose_reader_, [&](const std::vector<std::uint8_t>& bytes, const fdds::SampleInfo&) {
      try {
        if (auto why = ros2::addPoseMessage(tf_, pose_type_, bytes, options_.frames.base_frame)) {
          ++refused;
          spdlog::warn("{}: {}", options_.frames.pose_topic, *why);
        }
      } catch (const ros2::DecodeError& e) {
        ++undecodable;
        spdlog::warn("{}: undecodable {}: {}", options_.frames.pose_topic, pose_type_, e.what());
      }
    });
  }
  std::lock_guard lock(mutex_);
  counters_.tf_refused += refused;
  counters_.tf_undecodable += undecodable;
  wake_.notify_all();
}

bool Ros2Edge::tryPlace(Pending& p, std::string& why) {
  ros2::TfLookup pose;
  {
    std::lock_guard lock(tf_mutex_);
    pose =
        tf_.lookup(options_.frames.fixed_frame, p.cloud.header.frame_id, p.cloud.header.stamp.nanoseconds());
  }
  if (pose.status != ros2::TfLookup::Status::kOk) {
    why = pose.reason;
    return false;
  }
  const std::string robot = p.cloud.header.frame_id + "@" + options_.frames.cloud_topic;
  std::uint64_t seq;
  {
    std::lock_guard lock(mutex_);
    // The cloud's stamp is its sequence number: unique per sensor and the same after either side
    // restarts, so a journaled cloud sent again (a bag replayed, a bridge reconnecting) is applied once.
    const std::int64_t stamp = p.cloud.header.stamp.nanoseconds();
    seq = stamp > 0 ? static_cast<std::uint64_t>(stamp) : next_seq_++;
    ++counters_.clouds_submitted;
    tf_wait_.add(std::chrono::duration<double, std::milli>(Clock::now() - p.arrived).count());
  }
  ScanJob job = toScanJob(std::move(p.cloud), ros2::sensorPoseOf(pose.transform), robot, seq,
                          options_.pointcloud_min_z, options_.pointcloud_max_z);
  job.publish_ns = p.source_ns;
  job.received_ns = p.received_ns;
  service_.submit(std::move(job));
  return true;
}

void Ros2Edge::placeWaiting() {
  // In arrival order; what waited too long is dropped (tf2's message filter). pending_ is this thread's.
  const auto timeout = std::chrono::duration<double>(options_.tf_timeout_s);
  std::deque<Pending> still;
  for (Pending& p : pending_) {
    std::string why;
    if (tryPlace(p, why)) continue;
    if (Clock::now() - p.arrived > timeout) {
      spdlog::warn("{}: cloud of frame '{}' at {} ns dropped: no transform to '{}' within {} s ({})",
                   options_.frames.cloud_topic, p.cloud.header.frame_id, p.cloud.header.stamp.nanoseconds(),
                   options_.frames.fixed_frame, options_.tf_timeout_s, why);
      std::lock_guard lock(mutex_);
      ++counters_.clouds_waited_out;
      continue;
    }
    still.push_back(std::move(p));
  }
  pending_.swap(still);
}

void Ros2Edge::intakeLoop() {
  msg::RawSample sample;
  fdds::SampleInfo info;
  while (running_) {
    {
      std::unique_lock lock(mutex_);
      wake_.wait_for(lock, std::chrono::milliseconds(20));
    }
    if (!running_) break;
    placeWaiting();  // transforms may have come
    // One cloud at a time, each placed before the next is taken: the TF queue holds only clouds that wait
    // for a transform, and a busy pipeline (submit blocks under --overflow-policy wait) leaves the rest in
    // DDS, where a best-effort publisher's samples are dropped as ROS 2's would be.
    while (running_ && cloud_reader_->take_next_sample(&sample, &info) == ReturnCode_t::RETCODE_OK) {
      if (!info.valid_data) continue;
      std::string why;
      std::optional<ReceivedCloud> cloud = decodeCloud(sample.bytes, why);
      {
        std::lock_guard lock(mutex_);
        ++counters_.clouds_received;
        if (!cloud) ++counters_.clouds_undecodable;
      }
      if (!cloud) {
        spdlog::warn("{}: PointCloud2 refused: {}", options_.frames.cloud_topic, why);
        continue;
      }
      if (pending_.size() >= options_.tf_queue) {
        spdlog::warn("{}: cloud of frame '{}' pushed out of the TF queue ({} clouds wait for transforms)",
                     options_.frames.cloud_topic, pending_.front().cloud.header.frame_id, pending_.size());
        pending_.pop_front();
        std::lock_guard lock(mutex_);
        ++counters_.clouds_queue_dropped;
      }
      pending_.push_back({std::move(*cloud), Clock::now(), toNs(info.source_timestamp), msg::nowNs()});
      placeWaiting();
    }
  }
}

void Ros2Edge::publishMaps(bool force) {
  auto wanted = [&](fdds::DataWriter* w) {
    fdds::PublicationMatchedStatus s;
    w->get_publication_matched_status(s);
    return options_.latch || s.current_count > 0;  // octomap_server publishes only what someone reads
  };
  const bool any =
      wanted(binary_writer_) || wanted(full_writer_) || wanted(projected_writer_) || wanted(centres_writer_);
  const std::uint64_t version = service_.mapStore().version();
  if (!any || (!force && version == published_version_)) return;
  // A copy, so encoding does not hold the map's writer out.
  std::unique_ptr<map::OccupancyMap> copy =
      service_.mapStore().read([](const map::OccupancyMap& m, std::uint64_t) { return m.clone(); });
  ros2::Header header;
  header.frame_id = options_.frames.fixed_frame;
  header.stamp = ros2::Time::fromNanoseconds(msg::nowNs());
  auto write = [&](fdds::DataWriter* w, std::vector<std::uint8_t> bytes) {
    if (!wanted(w)) return;
    msg::RawSample s{std::move(bytes)};
    if (!w->write(&s)) spdlog::warn("could not publish {}", w->get_topic()->get_name());
  };
  write(binary_writer_, octomapMessage(*copy, true, header));
  write(full_writer_, octomapMessage(*copy, false, header));
  write(projected_writer_,
        projectedMapMessage(*copy, options_.occupancy_min_z, options_.occupancy_max_z, header));
  write(centres_writer_, occupiedCentresMessage(*copy, header));
  published_version_ = version;
  std::lock_guard lock(mutex_);
  ++counters_.maps_published;
}

void Ros2Edge::publishLoop() {
  const auto period =
      std::chrono::duration<double>(options_.map_publish_period_s > 0 ? options_.map_publish_period_s : 0.1);
  while (running_) {
    {
      std::unique_lock lock(mutex_);
      // Woken only by stop(): a steady period, not every cloud.
      wake_.wait_for(lock, std::chrono::duration_cast<Clock::duration>(period),
                     [&] { return !running_.load(); });
    }
    if (!running_) break;
    try {
      publishMaps(false);
    } catch (const std::exception& e) {
      spdlog::error("publishing the ROS 2 maps failed: {}", e.what());
    }
  }
}

void Ros2Edge::publishDiscoveryInfo() {
  ros2::NodeEntities entities;
  entities.node_name = options_.node_name;
  for (auto* r : {cloud_reader_, tf_reader_, tf_static_reader_, pose_reader_})
    if (r) entities.readers.push_back(guidBytes(r->guid()));
  for (auto* w : {binary_writer_, full_writer_, projected_writer_, centres_writer_})
    entities.writers.push_back(guidBytes(w->guid()));
  for (const auto& svc : services_) {
    entities.readers.push_back(guidBytes(svc->requests->guid()));
    entities.writers.push_back(guidBytes(svc->replies->guid()));
  }
  ros2::ParticipantEntities info;
  info.participant = guidBytes(node_->participant().guid());
  info.nodes.push_back(std::move(entities));
  const ros2::RosDistribution distribution = ros2::parseRosDistribution(options_.ros_distribution);
  auto* topic = node_->topic(ros2::kDiscoveryInfoTopic, msg::rawCdrType(ros2::kDiscoveryInfoType));
  discovery_info_writer_ = node_->writer(topic, msg::writerQos(ros2::Qos::tfStatic()));
  msg::RawSample sample{ros2::encode(info, distribution)};
  if (!discovery_info_writer_->write(&sample)) spdlog::warn("could not publish ros_discovery_info");
}

void Ros2Edge::handle(Service& s) {
  takeAll(s.requests, [&](const std::vector<std::uint8_t>& sample, const fdds::SampleInfo& info) {
    // rmw_cyclonedds frames the request with a header in the payload; every other requester is read as
    // rmw_fastrtps sends (ros2/service_framing.h).
    const ros2::ServiceFraming framing =
        ros2::serviceFramingOfVendor(vendors_->vendorOf(info.sample_identity.writer_guid()));
    ros2::FramedRequest request;
    try {
      request = ros2::unframeRequest(sample, framing);
    } catch (const ros2::DecodeError& e) {
      refuseRequest(s, framing, e.what());
      return;
    }
    const std::vector<std::uint8_t>& bytes = request.message;
    // rmw_fastrtps: the reply goes to the client's reply reader (related_sample_identity's writer guid,
    // when the client sent one), carrying the request's sequence number.
    eprosima::fastrtps::rtps::SampleIdentity identity = info.sample_identity;
    const bool names_its_reader =
        info.related_sample_identity.writer_guid() != eprosima::fastrtps::rtps::GUID_t::unknown();
    if (names_its_reader) identity.writer_guid(info.related_sample_identity.writer_guid());
    std::vector<std::uint8_t> reply;
    std::string why;
    bool ok = true;
    switch (s.kind) {
      case Service::Kind::kClearBox:
        if (auto box = toClearBox(bytes, why)) {
          const CommandResult r = service_.execute(*box, "ROS 2 " + s.name);
          if (r.status != Status::kOk) spdlog::warn("{}: {}", s.name, r.message);
          reply = ros2::encodeEmpty();
        } else {
          ok = false;
        }
        break;
      case Service::Kind::kReset:
        try {
          ros2::decodeEmpty(bytes);
          service_.execute(ResetCommand{}, "ROS 2 " + s.name);
          reply = ros2::encodeEmpty();
        } catch (const ros2::DecodeError& e) {
          why = e.what();
          ok = false;
        }
        break;
      case Service::Kind::kGetBinary:
      case Service::Kind::kGetFull: {
        try {
          ros2::decodeEmpty(bytes);
        } catch (const ros2::DecodeError& e) {
          why = e.what();
          ok = false;
          break;
        }
        auto copy =
            service_.mapStore().read([](const map::OccupancyMap& m, std::uint64_t) { return m.clone(); });
        ros2::Header header;
        header.frame_id = options_.frames.fixed_frame;
        header.stamp = ros2::Time::fromNanoseconds(msg::nowNs());
        reply = octomapMessage(*copy, s.kind == Service::Kind::kGetBinary, header);
        break;
      }
    }
    if (!ok) {
      refuseRequest(s, framing, why);
      return;
    }
    {
      std::lock_guard lock(mutex_);
      ++counters_.service_requests;
      if (framing == ros2::ServiceFraming::kRequestHeader) ++counters_.service_requests_header;
    }
    // Only a client that named its reply reader can be waited for (otherwise the GUID is its writer's).
    if (names_its_reader && !s.reply_readers.waitFor(identity.writer_guid(), kReplyReaderWait)) {
      std::lock_guard lock(mutex_);
      ++counters_.replies_unmatched;
      spdlog::warn(
          "{}: the client's reply reader was not matched within {} ms; replying anyway, it may not "
          "arrive (the client should retry)",
          s.name, kReplyReaderWait.count());
    }
    eprosima::fastrtps::rtps::WriteParams params;
    params.related_sample_identity(identity);
    msg::RawSample out{ros2::frameReply(request, std::move(reply))};
    if (!s.replies->write(&out, params)) spdlog::warn("{}: could not send the reply", s.name);
  });
}

void Ros2Edge::refuseRequest(const Service& s, ros2::ServiceFraming framing, const std::string& why) {
  {
    std::lock_guard lock(mutex_);
    ++counters_.service_requests;
    ++counters_.service_refused;
  }
  msg::countUndecodableSample();  // in the server's samples_undecodable too
  // ROS 2 services have no error reply: the client times out, as it would with octomap_server.
  spdlog::warn("{}: request refused, nothing done: {} (read in the {} framing)", s.name, why,
               ros2::toString(framing));
}

void Ros2Edge::serviceLoop() {
  while (running_) {
    {
      std::unique_lock lock(mutex_);
      wake_.wait_for(lock, std::chrono::milliseconds(20));
    }
    if (!running_) break;
    for (auto& s : services_) handle(*s);
  }
}

}  // namespace densemap::server::ros2_edge
