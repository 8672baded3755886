#include "densemap/server/dds_edge/dds_edge.h"

#include <pthread.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <sstream>
#include <thread>

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>

#include "densemap/msg/dds_options_cli.h"
#include "densemap/msg/peer_topic.h"
#include "densemap/msg/wire_types.h"
#include "densemap/server/dds_edge/wire.h"
#include "densemap/util/log_throttle.h"
#include "densemap/util/realtime_priority.h"
#include "densemap/util/retain_freed_memory.h"
#include "densemap/util/scheduler_slice.h"

namespace densemap::server::dds_edge {

namespace fdds = eprosima::fastdds::dds;
using namespace std::chrono_literals;

class DdsEdge::Listener : public fdds::DataReaderListener {
 public:
  explicit Listener(DdsEdge& e) : e_(e) {}
  // Readers are told apart by identity: the listener is attached only once every reader exists.
  void on_data_available(fdds::DataReader* reader) override {
    if (reader == e_.query_reader_) {
      e_.takeQueries();
    } else if (reader == e_.admin_reader_) {
      e_.takeCommands();
    } else if (reader == e_.stats_reader_) {
      e_.takeStatistics();
    }
  }
  void on_subscription_matched(fdds::DataReader* reader,
                               const fdds::SubscriptionMatchedStatus& info) override {
    spdlog::debug("{}: {} writer(s) matched", reader->get_topicdescription()->get_name(), info.current_count);
  }

 private:
  DdsEdge& e_;
};

// Remote readers of our per-peer topics and remote writers of robots' scan topics, as discovery finds them
// (DDS's thread): the writers are made before those clients ask, the readers before those robots send.
// What is found before the edge's side exists is passed on once it does.
class DdsEdge::DiscoveryListener : public fdds::DomainParticipantListener {
 public:
  /// `peer_bases`: the per-peer topic bases as on the wire (under the namespace).
  explicit DiscoveryListener(std::vector<std::string> peer_bases) : peer_bases_(std::move(peer_bases)) {}
  void on_publisher_discovery(fdds::DomainParticipant*,
                              eprosima::fastrtps::rtps::WriterDiscoveryInfo&& info) override {
    using Status = eprosima::fastrtps::rtps::WriterDiscoveryInfo::DISCOVERY_STATUS;
    if (info.status != Status::DISCOVERED_WRITER && info.status != Status::REMOVED_WRITER) return;
    std::string topic = info.info.topicName().to_string();
    if (!namesAPeer(topic)) return;
    logPeer(topic, info.status == Status::DISCOVERED_WRITER);
    if (info.status != Status::DISCOVERED_WRITER) return;
    std::lock_guard lock(mutex_);
    if (scans_ == nullptr) {
      if (early_writers_.size() < 4096) early_writers_.push_back(std::move(topic));
      return;
    }
    scans_->writerDiscovered(topic);
  }
  void on_subscriber_discovery(fdds::DomainParticipant*,
                               eprosima::fastrtps::rtps::ReaderDiscoveryInfo&& info) override {
    using Status = eprosima::fastrtps::rtps::ReaderDiscoveryInfo::DISCOVERY_STATUS;
    if (info.status != Status::DISCOVERED_READER && info.status != Status::REMOVED_READER) return;
    std::string topic = info.info.topicName().to_string();
    if (!namesAPeer(topic)) return;
    logPeer(topic, info.status == Status::DISCOVERED_READER);
    if (info.status != Status::DISCOVERED_READER) return;
    std::lock_guard lock(mutex_);
    if (targets_.empty()) {
      if (early_.size() < 4096) early_.push_back(std::move(topic));
      return;
    }
    for (ReplyWriters* w : targets_) w->readerDiscovered(topic);
  }
  // A remote participant that failed authentication (another CA, expired, revoked, forged permissions).
  void onParticipantAuthentication(fdds::DomainParticipant*,
                                   eprosima::fastrtps::rtps::ParticipantAuthenticationInfo&& info) override {
    if (info.status != eprosima::fastrtps::rtps::ParticipantAuthenticationInfo::UNAUTHORIZED_PARTICIPANT)
      return;
    std::ostringstream guid;
    guid << info.guid.guidPrefix;
    // Fast DDS retries the handshake every second or so: count each participant once (past the bound, a
    // flood of new ones counts every attempt, never less than there were).
    std::uint64_t n = 0;
    {
      std::lock_guard lock(mutex_);
      if (refused_guids_.size() >= kMaxRememberedRefusals || refused_guids_.insert(guid.str()).second) {
        n = ++refused_;
      }
    }
    if (n == 0 || !log_.due()) return;  // a flood stays cheap to log
    spdlog::warn(
        "DDS-Security: refused participant {} (authentication or its permissions failed: another CA, an "
        "expired or revoked certificate, or permissions not signed by our CA); {} refused so far",
        guid.str(), n);
  }
  std::uint64_t refused() const { return refused_; }
  std::uint64_t namesRefused() const { return names_refused_; }

  void ready(std::vector<ReplyWriters*> targets) {
    std::lock_guard lock(mutex_);
    targets_ = std::move(targets);
    for (const std::string& t : early_)
      for (ReplyWriters* w : targets_) w->readerDiscovered(t);
    early_.clear();
  }
  void readyForScans(ScanReaders* scans) {
    std::lock_guard lock(mutex_);
    scans_ = scans;
    for (const std::string& t : early_writers_) scans_->writerDiscovered(t);
    early_writers_.clear();
  }
  void detachScans() {
    std::lock_guard lock(mutex_);
    scans_ = nullptr;
  }
  void detach() {
    std::lock_guard lock(mutex_);
    targets_.clear();
    scans_ = nullptr;
  }

 private:
  std::mutex mutex_;
  std::vector<ReplyWriters*> targets_;
  std::vector<std::string> early_;
  ScanReaders* scans_ = nullptr;
  std::vector<std::string> early_writers_;
  static constexpr std::size_t kMaxRememberedRefusals = 65536;
  std::set<std::string> refused_guids_;  // guarded by mutex_
  std::atomic<std::uint64_t> refused_{0};
  util::LogThrottle log_;
  const std::vector<std::string> peer_bases_;
  std::atomic<std::uint64_t> names_refused_{0};
  util::LogThrottle names_log_;

  /// One line when a robot (its scan writer) or a client (its query or admin reply reader) is first seen
  /// and one when it goes: per endpoint, never per sample. Its other endpoints (acks, progress) are quiet.
  void logPeer(const std::string& topic, bool arrived) {
    const struct {
      std::size_t base;
      const char* what;
      const char* endpoint;
    } kinds[] = {{0, "robot", "scan writer"},
                 {3, "client", "query reply reader"},
                 {4, "client", "admin reply reader"}};
    for (const auto& k : kinds) {
      const auto id = msg::peerOfTopic(peer_bases_[k.base], topic);
      if (!id) continue;
      if (arrived) {
        spdlog::info("{} '{}' matched ({} on {})", k.what, *id, k.endpoint, topic);
      } else {
        spdlog::info(
            "{} '{}' left: its {} is gone (closed by the program, or its participant's lease ended: after a "
            "kill "
            "-9, a crash or a cut link this line comes only when the lease runs out, 20 s by default)",
            k.what, *id, k.endpoint);
      }
    }
  }

  /// False (counted, logged) for an endpoint on a per-peer topic whose last segment is no escape of a
  /// valid id (msg/peer_topic.h): e.g. a client that wrote "robot-0" into the name unescaped. Such a peer
  /// would never be answered, so it is told in the log rather than left waiting in silence.
  bool namesAPeer(const std::string& topic) {
    for (const std::string& base : peer_bases_) {
      if (!msg::isUnderPeerBase(base, topic) || msg::peerOfTopic(base, topic)) continue;
      const std::uint64_t n = ++names_refused_;
      if (names_log_.due()) {
        spdlog::warn(
            "DDS endpoint on '{}' ignored: '{}' is not a peer id written as densemap writes ids into topic "
            "names ('_' -> '__', '-' -> '_h', '.' -> '_d'; ids of 1-63 letters, digits, '_', '.', '-'); {} "
            "such endpoints so far",
            topic, topic.substr(base.size() + 1), n);
      }
      return false;
    }
    return true;
  }
};

std::uint64_t DdsEdge::participantsRefused() const { return discovery_->refused(); }
std::uint64_t DdsEdge::peerTopicsRefused() const { return discovery_->namesRefused(); }

msg::ServerStatistics DdsEdge::statisticsMessage(const ServiceStatistics& s) const {
  msg::ServerStatistics m = toWire(s);
  m.participants_refused(participantsRefused());  // the edge's own count: the service never sees DDS peers
  m.peer_topics_refused(peerTopicsRefused());
  return m;
}

DdsEdge::DdsEdge(MapService& service, const DdsEdgeOptions& options) : service_(service), options_(options) {
  // Threads created from here on (DDS's receive threads, the query threads) inherit the short slice; the
  // scan intake sets the default back for itself (the pipeline's threads were created before).
  {
    DdsEdgeOptions copy = options_;  // checked against the option tables, the one place ranges live
    std::vector<options::OptionTable> tables;
    tables.push_back(msg::ddsOptions(copy.dds));
    tables.push_back(edgeOptions(copy));
    for (const options::OptionTable& t : tables) {
      if (const std::string why = t.validate(); !why.empty()) throw std::invalid_argument(why);
    }
  }
  util::requestSchedulerSlice(std::chrono::microseconds(options_.latency_slice_us));
  listener_ = std::make_unique<Listener>(*this);
  // Real-time from here to the end: DDS's threads (they answer point and ray queries) and the query threads
  // inherit it; the intake, admin, ack and statistics threads drop it, and so does this thread at the end.
  const bool realtime =
      options_.realtime_priority > 0 && util::setRealtimePriority(options_.realtime_priority);
  if (options_.realtime_priority > 0 && !realtime) {
    spdlog::warn(
        "--realtime-priority {}: this process may not use SCHED_FIFO; DDS and query threads run at "
        "normal priority. To allow it: {}",
        options_.realtime_priority, util::realtimePriorityHint());
  } else if (realtime) {
    spdlog::info("DDS and query threads at SCHED_FIFO priority {}", options_.realtime_priority);
  }
  try {
    msg::DdsOptions dds = options_.dds;
    dds.name = service_.options().server_id;
    dds.announce_server = true;
    {
      std::vector<std::string> bases;  // as on the wire (DdsNode::topicName), before the node exists
      const std::string ns = dds.topic_namespace.empty() ? "" : dds.topic_namespace + "/";
      for (const char* base : {msg::kScanTopic, msg::kScanAckTopic, msg::kRobotProgressTopic,
                               msg::kQueryReplyTopic, msg::kAdminReplyTopic})
        bases.push_back(ns + base);
      discovery_ = std::make_unique<DiscoveryListener>(std::move(bases));
    }
    node_ = std::make_unique<msg::DdsNode>(dds, discovery_.get());
    auto* requests = node_->topic(msg::kQueryRequestTopic, msg::typeSupport<msg::QueryRequestPubSubType>());
    auto* admin_requests =
        node_->topic(msg::kAdminRequestTopic, msg::typeSupport<msg::AdminRequestPubSubType>());
    auto* stats = node_->topic(msg::kStatisticsTopic, msg::typeSupport<msg::ServerStatisticsPubSubType>());
    acks_ =
        std::make_unique<ReplyWriters>(*node_, msg::kScanAckTopic, msg::typeSupport<msg::ScanAckPubSubType>,
                                       msg::kMessageWriterProfile, service_.options().pipeline.max_robots);
    // A robot's progress writer starts with the robot's progress: a robot reads it first (transient local).
    robot_progress_ = std::make_unique<ReplyWriters>(
        *node_, msg::kRobotProgressTopic, msg::typeSupport<msg::RobotProgressPubSubType>,
        msg::progressWriterQos(), service_.options().pipeline.max_robots,
        [this](const std::string& robot, fdds::DataWriter& w) { writeRobotProgress(robot, w); });
    replies_ = std::make_unique<ReplyWriters>(*node_, msg::kQueryReplyTopic,
                                              msg::typeSupport<msg::QueryReplyPubSubType>,
                                              msg::kReplyWriterProfile, options_.max_clients);
    admin_replies_ = std::make_unique<ReplyWriters>(*node_, msg::kAdminReplyTopic,
                                                    msg::typeSupport<msg::AdminReplyPubSubType>,
                                                    msg::kReplyWriterProfile, options_.max_clients);
    discovery_->ready({replies_.get(), admin_replies_.get(), acks_.get(), robot_progress_.get()});
    stats_writer_ = node_->writer(stats, msg::kMessageWriterProfile);
    auto* progress = node_->topic(msg::kRobotProgressTopic, msg::typeSupport<msg::RobotProgressPubSubType>());
    progress_writer_ = node_->writer(progress, msg::progressWriterQos());
    incarnation_ = static_cast<std::uint64_t>(msg::nowNs()) ^ (static_cast<std::uint64_t>(::getpid()) << 48);
    // Another server on these topics shows itself by its statistics. Look before taking any scan or query.
    {
      const msg::ServerStatistics own = toWire(service_.statistics());
      started_ns_ = serverStartNs(own).value_or(own.stamp_ns());
    }
    stats_reader_ = node_->reader(stats, msg::kMessageReaderProfile, listener_.get());
    checkForAnotherServer();
    scans_ = std::make_unique<ScanReaders>(*node_, service_.options().pipeline.max_robots,
                                           [this] { scans_ready_.notify_one(); });
    discovery_->readyForScans(scans_.get());
    query_reader_ = node_->reader(requests, msg::kMessageReaderProfile, nullptr);
    admin_reader_ = node_->reader(admin_requests, msg::kMessageReaderProfile, nullptr);
    for (auto* r : {query_reader_, admin_reader_}) r->set_listener(listener_.get());
    // What a reconnecting robot resumes from (it resends what follows); each robot's own goes out as its
    // progress writer is made.
    publishProgress();
  } catch (...) {
    util::setRealtimePriority(0);
    throw;
  }
  ingest_thread_ = std::thread([this] {
    pthread_setname_np(pthread_self(), "dm-ingest");
    util::useBulkScheduling();  // taking and converting scans is bulk work
    ingestLoop();
  });
  for (int i = 0; i < std::max(1, options_.query_threads); ++i)
    query_threads_.emplace_back([this] {
      pthread_setname_np(pthread_self(), "dm-query");
      queryLoop();
    });
  admin_thread_ = std::thread([this] {
    pthread_setname_np(pthread_self(), "dm-admin");
    util::useBulkScheduling();
    adminLoop();
  });
  ack_thread_ = std::thread([this] {
    pthread_setname_np(pthread_self(), "dm-acks");
    util::useBulkScheduling();
    ackLoop();
  });
  stats_thread_ = std::thread([this] {
    pthread_setname_np(pthread_self(), "dm-statistics");
    util::useBulkScheduling();
    statisticsLoop();
  });
  if (realtime) util::setRealtimePriority(0);
  // Requests that arrived before the listener was attached.
  takeQueries();
  takeCommands();
  const ServiceOptions& so = service_.options();
  spdlog::info("{} serving on DDS domain {} ({}): {} map at {} m, method {}, overflow policy {}",
               so.server_id, options_.dds.domain, options_.dds.loopback ? "loopback" : "all interfaces",
               so.map.backend, so.map.resolution, update::toString(so.update.method),
               toString(so.pipeline.overflow));
  msg::logSecurity(*node_, "densemap topics");
}

DdsEdge::~DdsEdge() { stop(); }

void DdsEdge::checkForAnotherServer() {
  if (options_.duplicate_check_s <= 0) return;
  // Announce ourselves meanwhile (a running server then sees us too), every 200 ms: a message written
  // before discovery has matched is lost.
  const auto end =
      std::chrono::steady_clock::now() + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                             std::chrono::duration<double>(options_.duplicate_check_s));
  while (std::chrono::steady_clock::now() < end) {
    msg::ServerStatistics m = statisticsMessage(service_.statistics());
    stats_writer_->write(&m);
    std::this_thread::sleep_for(200ms);
  }
  if (refused_) {
    std::lock_guard lock(peers_mutex_);
    throw AnotherServerError(fmt::format(
        "another densemap-server ('{}') already serves {} on DDS domain {}; this one does not start (two "
        "servers would both map every scan and answer every query, and their maps drift apart). Stop it, or "
        "give each server its own --namespace",
        refused_by_,
        options_.dds.topic_namespace.empty() ? "the topics"
                                             : "namespace '" + options_.dds.topic_namespace + "'",
        options_.dds.domain));
  }
}

void DdsEdge::takeStatistics() {
  msg::ServerStatistics m;
  fdds::SampleInfo info;
  while (stats_reader_->take_next_sample(&m, &info) == ReturnCode_t::RETCODE_OK) {
    if (!info.valid_data || info.publication_handle == stats_writer_->get_instance_handle()) continue;
    const fdds::InstanceHandle_t writer = info.publication_handle;
    // A message whose stamp or uptime cannot be real never makes this server give way.
    const std::int64_t other_start = serverStartNs(m).value_or(std::numeric_limits<std::int64_t>::max());
    std::lock_guard lock(peers_mutex_);
    if (std::find(other_servers_.begin(), other_servers_.end(), writer) != other_servers_.end()) continue;
    other_servers_.push_back(writer);
    // The newer of the two gives way (ties: the smaller writer id stays), so exactly one keeps serving.
    const bool we_are_newer = other_start < started_ns_ ||
                              (other_start == started_ns_ && writer < stats_writer_->get_instance_handle());
    spdlog::error(
        "another densemap-server ('{}', started {:.1f} s {}) serves the same topics on DDS domain {}{}: both "
        "would map every scan and answer every query. {}",
        m.server_id(), std::abs(static_cast<double>(started_ns_) - static_cast<double>(other_start)) / 1e9,
        other_start < started_ns_ ? "before this one" : "after this one", options_.dds.domain,
        options_.dds.topic_namespace.empty() ? "" : " namespace '" + options_.dds.topic_namespace + "'",
        we_are_newer ? "This one gives way and stops." : "It was started later and gives way.");
    if (we_are_newer && !refused_) {
      refused_by_ = m.server_id();
      refused_ = true;
    }
  }
}

void DdsEdge::queueAck(const ScanJob& job, ScanOutcome outcome, const std::string& why) {
  // On a pipeline thread: only queue (the ack thread writes), so DDS never holds up the map's writer.
  msg::ScanAck ack = toAck(job, outcome, why);
  {
    std::lock_guard lock(wake_mutex_);
    ack_backlog_.push_back(std::move(ack));
  }
  acks_ready_.notify_one();
}

namespace {
// The scan as the service takes it, from robot `robot`'s topic. The topic names the sender (in secure mode
// the permissions let only that identity write it), so a scan labelled another robot is refused, and
// counted and acknowledged as the topic's robot's.
ScanJob scanFromTopic(const msg::Scan& m, const std::string& robot, std::string& why) {
  ScanJob job = toScanJob(m, why);
  job.received_ns = msg::nowNs();
  if (job.robot_id != robot) {
    why = fmt::format(
        "the scan says robot '{}' but came on robot '{}''s topic: a robot sends only its own scans, on "
        "densemap/scans/<its robot id>",
        job.robot_id, robot);
    job.robot_id = robot;
  }
  return job;
}
}  // namespace

void DdsEdge::ingestLoop() {
  msg::Scan m;
  std::string robot;
  auto ack = [this](const ScanJob& j, ScanOutcome o, const std::string& why) { queueAck(j, o, why); };
  while (running_) {
    if (scans_->take(m, robot)) {
      std::string why;
      ScanJob job = scanFromTopic(m, robot, why);
      // Rejections are acknowledged through `ack` like every other outcome.
      if (why.empty()) {
        service_.submit(std::move(job), ack);
      } else {
        service_.refuse(job, why, ack);  // malformed as a message
      }
      continue;
    }
    std::unique_lock lock(wake_mutex_);
    scans_ready_.wait_for(lock, 20ms);
  }
}

void DdsEdge::takeQueries() {
  // Mostly on DDS's listener thread, which holds the request reader's lock: replies go out here only on a
  // client's existing writer (writeReplyIfMade); making one waits for DDS locks that a thread pairing a
  // new client's request writer with this reader holds while it waits for this reader's lock.
  msg::QueryRequest rq;
  fdds::SampleInfo info;
  while (query_reader_->take_next_sample(&rq, &info) == ReturnCode_t::RETCODE_OK) {
    if (!info.valid_data) continue;
    auto decoded = toQuery(rq);
    // A new client's first query goes to a query thread, which makes its writer.
    if (auto* q = std::get_if<Query>(&decoded);
        q != nullptr && answerInline(*q) && replies_->has(rq.client_id())) {
      msg::QueryReply rp = toReply(rq, service_.answer(*q));
      if (rp.status() != msg::STATUS_OK)
        spdlog::warn("query {}#{} failed: {}", rq.client_id(), rq.request_id(), rp.message());
      if (writeReplyIfMade(rp)) continue;
      // The writer went meanwhile (idle and unread): a query thread answers again and makes it anew.
    }
    {
      std::unique_lock lock(wake_mutex_);
      if (query_backlog_.size() >= options_.query_backlog) {
        lock.unlock();
        replyBusy(rq);
        continue;
      }
      query_backlog_.push_back(std::move(rq));
    }
    queries_ready_.notify_one();
    rq = msg::QueryRequest();
  }
}

bool DdsEdge::writeReplyIfMade(msg::QueryReply& rp) {
  rp.server_id(service_.options().server_id);
  switch (replies_->writeIfMade(rp.client_id(), &rp)) {
    case ReplyWriters::Written::kYes:
      return true;
    case ReplyWriters::Written::kRefused:
      service_.countRefusedQuery();
      logRefusedClient(rp.client_id(), "query");
      return true;  // handled: refused and counted
    case ReplyWriters::Written::kNoWriterYet:
      break;
  }
  return false;
}

void DdsEdge::writeReply(msg::QueryReply& rp) {
  rp.server_id(service_.options().server_id);
  if (!replies_->write(rp.client_id(), &rp)) {
    service_.countRefusedQuery();
    logRefusedClient(rp.client_id(), "query");
  }
}

void DdsEdge::writeAdminReply(msg::AdminReply& rp) {
  rp.server_id(service_.options().server_id);
  if (!admin_replies_->write(rp.client_id(), &rp)) {
    service_.countRefusedCommand();
    logRefusedClient(rp.client_id(), "command");
  }
}

void DdsEdge::logRefusedClient(const std::string& client_id, const char* what) {
  if (!refused_client_log_.due()) return;  // counted by the caller; a flood stays cheap to log
  const std::string why = msg::checkPeerId(client_id);
  spdlog::warn("{} from client '{}' not answered: {}", what, client_id,
               why.empty()
                   ? fmt::format("{} clients have reply topics already (--max-clients)", options_.max_clients)
                   : why);
}

void DdsEdge::replyBusy(const msg::QueryRequest& rq) {
  // Answered at once, so a flood gets answers in bounded time and the backlog stays bounded.
  service_.countBusyQuery();
  Answer busy;
  busy.status = Status::kBusy;
  busy.message = fmt::format("server busy: {} queries already waiting (query-backlog); retry later",
                             options_.query_backlog);
  msg::QueryReply rp = toReply(rq, std::move(busy));
  // A client whose writer is not made yet (it is made once its reply reader is discovered, normally long
  // before it asks) gets no busy reply: its call times out and it retries.
  if (!writeReplyIfMade(rp)) spdlog::debug("busy reply to new client '{}' not sent", rq.client_id());
}

bool DdsEdge::isLargeQuery(const msg::QueryRequest& rq) const {
  return rq.points().size() / 3 > options_.large_query_points ||
         (rq.kind() == msg::QUERY_BOX && rq.limit() > options_.large_query_points);
}

void DdsEdge::queryLoop() {
  for (;;) {
    msg::QueryRequest rq;
    {
      std::unique_lock lock(wake_mutex_);
      queries_ready_.wait(lock, [&] { return !query_backlog_.empty() || !workers_running_; });
      if (query_backlog_.empty()) return;
      rq = std::move(query_backlog_.front());
      query_backlog_.pop_front();
    }
    auto decoded = toQuery(rq);
    if (!std::holds_alternative<Query>(decoded)) service_.countRefusedQuery();
    Answer a = std::holds_alternative<Query>(decoded) ? service_.answer(std::get<Query>(decoded))
                                                      : std::move(std::get<Answer>(decoded));
    if (a.status != Status::kOk)
      spdlog::warn("query {}#{} failed: {}", rq.client_id(), rq.request_id(), a.message);
    msg::QueryReply rp = toReply(rq, std::move(a));
    writeReply(rp);
    if (isLargeQuery(rq)) {
      rp = msg::QueryReply();
      rq = msg::QueryRequest();
      util::returnFreedMemory();  // the request's and the answer's buffers
      // The reply's stays in the writer's history for its lifespan; the statistics thread trims after it.
      large_reply_ns_ = msg::nowNs();
    }
  }
}

void DdsEdge::takeCommands() {
  msg::AdminRequest rq;
  fdds::SampleInfo info;
  bool any = false;
  {
    std::lock_guard lock(wake_mutex_);
    while (admin_reader_->take_next_sample(&rq, &info) == ReturnCode_t::RETCODE_OK) {
      if (!info.valid_data) continue;
      admin_backlog_.push_back(std::move(rq));
      rq = msg::AdminRequest();
      any = true;
    }
  }
  if (any) commands_ready_.notify_one();
}

void DdsEdge::adminLoop() {
  for (;;) {
    msg::AdminRequest rq;
    {
      std::unique_lock lock(wake_mutex_);
      commands_ready_.wait(lock, [&] { return !admin_backlog_.empty() || !workers_running_; });
      if (admin_backlog_.empty()) return;
      rq = std::move(admin_backlog_.front());
      admin_backlog_.pop_front();
    }
    auto decoded = toCommand(rq);
    CommandResult r;
    if (const auto* c = std::get_if<Command>(&decoded)) {
      r = service_.execute(*c, rq.client_id());
    } else if (const auto* refused = std::get_if<CommandResult>(&decoded)) {
      r = *refused;
      service_.countRefusedCommand();
      spdlog::warn("command {}#{} refused: {}", rq.client_id(), rq.request_id(), r.message);
    } else {
      r.message = "pong";  // ADMIN_PING
    }
    msg::AdminReply rp = toReply(rq, r);
    writeAdminReply(rp);
  }
}

void DdsEdge::publishProgress(const std::set<std::string>& robots) {
  const durability::RobotProgress p = service_.durableProgress();
  const ServiceOptions& so = service_.options();
  msg::RobotProgress m = toWire(p, so.server_id, incarnation_, so.durability.journal);
  progress_writer_->write(&m);
  for (const std::string& robot : robots) {
    msg::RobotProgress own = toWire(p, so.server_id, incarnation_, so.durability.journal, robot);
    robot_progress_->write(robot, &own);
  }
}

void DdsEdge::writeRobotProgress(const std::string& robot, fdds::DataWriter& writer) {
  const ServiceOptions& so = service_.options();
  msg::RobotProgress m =
      toWire(service_.durableProgress(), so.server_id, incarnation_, so.durability.journal, robot);
  writer.write(&m);
}

void DdsEdge::ackLoop() {
  // Robot progress goes out with the acknowledgements, at most every 100 ms (a reconnecting robot reads
  // the last one: transient local), and once more when nothing new came for 100 ms.
  auto last_progress = std::chrono::steady_clock::now();
  std::set<std::string> progress_due;  // robots with a durable scan since the last progress
  for (;;) {
    std::deque<msg::ScanAck> batch;
    {
      std::unique_lock lock(wake_mutex_);
      acks_ready_.wait_for(lock, 100ms, [&] { return !ack_backlog_.empty() || !workers_running_; });
      if (ack_backlog_.empty() && !workers_running_) break;
      batch.swap(ack_backlog_);
    }
    for (msg::ScanAck& a : batch) {
      a.server_id(service_.options().server_id);
      acks_->write(a.robot_id(), &a);  // refused (counted) only past max_robots
      if (a.durable()) progress_due.insert(a.robot_id());
    }
    if (!progress_due.empty() && std::chrono::steady_clock::now() - last_progress >= 100ms) {
      publishProgress(progress_due);
      last_progress = std::chrono::steady_clock::now();
      progress_due.clear();
    }
  }
  if (!progress_due.empty()) publishProgress(progress_due);
}

void DdsEdge::statisticsLoop() {
  if (options_.statistics_period_s <= 0) return;
  const auto period = std::chrono::duration<double>(options_.statistics_period_s);
  auto next = std::chrono::steady_clock::now();
  std::uint64_t last_logged = ~0ull;
  while (running_) {
    next += std::chrono::duration_cast<std::chrono::steady_clock::duration>(period);
    {
      std::unique_lock lock(wake_mutex_);
      stats_wake_.wait_until(lock, next, [&] { return !running_.load(); });
    }
    if (!running_) break;
    if (const std::int64_t t = large_reply_ns_.load();
        t != 0 && msg::nowNs() - t > static_cast<std::int64_t>((msg::kReplyLifespanS + 1.0) * 1e9)) {
      large_reply_ns_ = 0;
      util::returnFreedMemory();  // the large replies have left the history
    }
    const ServiceStatistics s = service_.statistics();
    msg::ServerStatistics m = statisticsMessage(s);
    stats_writer_->write(&m);
    const RobotCounters t = s.totals();
    const std::uint64_t activity = t.processed + t.rejected + t.dropped + s.queries_answered +
                                   s.queries_failed + s.commands_done + s.commands_failed;
    if (activity != last_logged) {  // log while something happens, stay quiet when idle
      spdlog::info("{}", s.summaryLine());
      last_logged = activity;
    }
  }
}

std::size_t DdsEdge::refuseScansStillInDds() {
  msg::Scan m;
  std::string robot;
  std::size_t refused = 0;
  auto ack = [this](const ScanJob& j, ScanOutcome o, const std::string& why) { queueAck(j, o, why); };
  while (scans_->take(m, robot)) {
    std::string why;
    ScanJob job = scanFromTopic(m, robot, why);
    service_.refuse(job, "the server is shutting down; the scan was not mapped (send it to a running server)",
                    ack);
    ++refused;
  }
  // Nothing more reaches these readers; a scan sent from here on is the robot's to resend (it gets no ack).
  discovery_->detachScans();
  scans_->removeAll();
  return refused;
}

void DdsEdge::stop() {
  std::lock_guard lock(stop_mutex_);
  if (stopped_) return;
  stopped_ = true;
  // Every scan taken from DDS ends mapped, dropped or rejected, and acknowledged. The intake
  // stops first. Draining, a scan it is still pushing into a full queue waits for space (the pipeline maps
  // on) and is mapped; dropping, stopping the service first releases that push and the scan is dropped.
  const bool drain = !service_.options().drop_on_exit;
  running_ = false;
  scans_ready_.notify_all();
  stats_wake_.notify_all();
  if (!drain) service_.stop(false);
  if (ingest_thread_.joinable()) ingest_thread_.join();
  service_.stop(drain);  // idempotent; the outcomes' acknowledgements are queued
  // What DDS still held when the intake closed: refused, each acknowledged, so robots know to resend.
  const std::size_t refused = scans_ != nullptr ? refuseScansStillInDds() : 0;
  if (stats_thread_.joinable()) stats_thread_.join();
  if (stats_writer_ != nullptr) {
    msg::ServerStatistics m = statisticsMessage(service_.statistics());
    stats_writer_->write(&m);
  }
  {
    std::lock_guard wake(wake_mutex_);
    workers_running_ = false;  // the threads finish their backlogs first
  }
  queries_ready_.notify_all();
  commands_ready_.notify_all();
  acks_ready_.notify_all();
  for (auto& t : query_threads_) {
    if (t.joinable()) t.join();
  }
  if (admin_thread_.joinable()) admin_thread_.join();
  if (ack_thread_.joinable()) ack_thread_.join();  // it writes its whole backlog first
  // Written is not delivered: deleting the participant drops what robots have not acknowledged yet.
  const bool delivered = acks_ == nullptr || acks_->waitForAcknowledgments(options_.ack_flush_s);
  const RobotCounters t = service_.statistics().totals();
  spdlog::info(
      "stopped: {} scans received, {} in map, {} dropped, {} rejected ({} still in DDS when the intake "
      "closed, refused); acknowledgements {}",
      t.received, t.processed, t.dropped, t.rejected, refused,
      delivered ? "all delivered"
                : fmt::format("not all confirmed within {} s (robots gone?)", options_.ack_flush_s));
  discovery_->detach();
  replies_->stop();
  admin_replies_->stop();
  acks_->stop();
  robot_progress_->stop();
  node_->close();
}

}  // namespace densemap::server::dds_edge
