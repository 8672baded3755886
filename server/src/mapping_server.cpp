#include "densemap/server/mapping_server.h"

#include <pthread.h>
#include <unistd.h>

#include <fstream>

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>

#include "densemap/dense/adaptive_kernel_layer.h"
#include "densemap/dense/isotropic_kernel_layer.h"
#include "densemap/map/grid_map.h"
#include "densemap/map/map_file.h"
#include "densemap/map/octree_map.h"
#include "densemap/msg/densemapPubSubTypes.h"
#include "densemap/server/occupancy_stage.h"
#include "densemap/server/update_priority.h"
#include "densemap/util/realtime_priority.h"
#include "densemap/util/scheduler_slice.h"

namespace densemap::server {

namespace dds = eprosima::fastdds::dds;
using namespace std::chrono_literals;

class MappingServer::Listener : public dds::DataReaderListener {
 public:
  explicit Listener(MappingServer& s) : s_(s) {}
  // Told apart by topic, not by the member pointers: data can arrive before create_datareader() returns.
  void on_data_available(dds::DataReader* reader) override {
    if (reader->get_topicdescription()->get_name() == msg::kScanTopic) {
      s_.scans_ready_.notify_one();
    } else {
      s_.takeQueries(reader);
    }
  }
  void on_subscription_matched(dds::DataReader* reader, const dds::SubscriptionMatchedStatus& info) override {
    spdlog::debug("{}: {} writer(s) matched", reader->get_topicdescription()->get_name(), info.current_count);
  }

 private:
  MappingServer& s_;
};

namespace {

std::unique_ptr<map::OccupancyMap> makeMap(const MapOptions& o) {
  if (const std::string why = o.params.validate(); !why.empty()) throw std::invalid_argument(why);
  if (!(o.resolution > 0.0)) throw std::invalid_argument("the map resolution must be positive");
  if (o.backend == "grid") return std::make_unique<map::GridMap>(o.resolution, o.params);
  if (o.backend == "octree") return std::make_unique<map::OctreeMap>(o.resolution, o.params);
  throw std::invalid_argument("unknown map backend '" + o.backend + "' (use grid or octree)");
}

std::unique_ptr<dense::KernelLayer> makeDenseLayer(const DenseLayerOptions& o, double map_resolution) {
  dense::KernelLayerOptions lo;
  lo.resolution = o.resolution > 0 ? o.resolution : map_resolution;
  lo.sampling.free_sample_distance = o.free_sample_distance;
  lo.sampling.max_range = o.max_range;
  lo.sampling.free_voxel_size = o.free_voxel_size;
  if (o.method == "akimap") {
    dense::AdaptiveKernelOptions a;
    a.layer = lo;
    a.isotropic_free_kernels = o.isotropic_free_kernels;
    a.min_occupied_search_radius = o.min_occupied_search_radius;
    return std::make_unique<dense::AdaptiveKernelLayer>(a);
  }
  if (o.method == "bgk") {
    dense::IsotropicKernelOptions b;
    b.layer = lo;
    return std::make_unique<dense::IsotropicKernelLayer>(b);
  }
  throw std::invalid_argument("unknown dense layer '" + o.method + "' (use none, akimap or bgk)");
}

std::uint64_t residentBytes() {
  std::ifstream statm("/proc/self/statm");
  std::uint64_t size = 0, resident = 0;
  statm >> size >> resident;
  return resident * static_cast<std::uint64_t>(sysconf(_SC_PAGESIZE));
}

/// The scan as the pipeline sees it; an empty `why` when the message itself is well formed.
ScanJob toJob(msg::Scan& m, std::string& why) {
  ScanJob job;
  job.robot_id = m.robot_id();
  job.seq = m.seq();
  job.publish_ns = m.publish_ns();
  job.received_ns = msg::nowNs();
  job.position = {m.sensor_pose().px(), m.sensor_pose().py(), m.sensor_pose().pz()};
  job.quaternion = {m.sensor_pose().qw(), m.sensor_pose().qx(), m.sensor_pose().qy(), m.sensor_pose().qz()};
  job.scan.index = m.seq();
  const std::string& frame = m.frame_id();
  job.scan.frame = (frame == "world" || frame == "map") ? io::PointFrame::kWorld : io::PointFrame::kSensor;
  const auto& xyz = m.points();
  if (job.robot_id.empty()) why = "the scan has no robot_id";
  if (xyz.size() % 3 != 0) why = "points must be packed x y z (got a length not divisible by 3)";
  if (why.empty()) {
    job.scan.points.resize(xyz.size() / 3);
    for (std::size_t i = 0; i < job.scan.points.size(); ++i) {
      job.scan.points[i] = geometry::Vec3f(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);
    }
  }
  const auto& g = m.lidar();
  if (g.rows() > 0 && g.columns() > 0) {
    job.scan.lidar =
        io::LidarGeometry{g.rows(), g.columns(), g.fov_up_deg(), g.fov_down_deg(), g.fov_horizontal_deg()};
  }
  return job;
}

/// Resolves update_nice (-1: auto) against what this process may do, and says what it chose.
UpdatePriorityOptions updatePriority(const ServerOptions& o) {
  if (o.update_nice < -1 || o.update_nice > 19)
    throw std::invalid_argument("update_nice must be -1 (auto) or 0..19, not " +
                                std::to_string(o.update_nice));
  if (o.update_catch_up_ms < 0) throw std::invalid_argument("update_catch_up_ms must be >= 0");
  UpdatePriorityOptions p;
  p.catch_up = std::chrono::milliseconds(o.update_catch_up_ms);
  if (o.update_late_nice < -20 || o.update_late_nice > 0)
    throw std::invalid_argument("update_late_nice must be -20..0, not " + std::to_string(o.update_late_nice));
  const bool can_raise = UpdatePriority::canRaisePriority();
  p.low_nice = o.update_nice >= 0 ? o.update_nice : can_raise ? 19 : 0;
  if (o.update_late_nice < 0) {
    if (p.low_nice == 0) {
      spdlog::warn(
          "--update-late-nice {} has no effect: the update always runs at normal priority (--update-nice "
          "0, or -1 without the right to raise priorities back)",
          o.update_late_nice);
    } else if (!UpdatePriority::canRaisePriority(o.update_late_nice)) {
      spdlog::warn(
          "late scans updated at nice 0, not {}: this process may not go below 0 (root, CAP_SYS_NICE "
          "or `ulimit -e {}`)",
          o.update_late_nice, 20 - o.update_late_nice);
    } else {
      p.late_nice = o.update_late_nice;
    }
  }
  if (p.low_nice > 0 && can_raise) {
    spdlog::info("map update at nice {} while scans are on time, nice {} once one is {} ms late", p.low_nice,
                 p.late_nice, o.update_catch_up_ms);
  } else if (p.low_nice > 0) {
    spdlog::warn(
        "map update at nice {}; this process may not raise it back when scans are late (no "
        "CAP_SYS_NICE, RLIMIT_NICE < 20), so a heavy query load can delay the map",
        p.low_nice);
  } else if (o.update_nice < 0) {
    spdlog::info(
        "map update at normal priority: to let queries go first, allow raising priorities back "
        "(`ulimit -e 20`, CAP_SYS_NICE or root)");
  }
  return p;
}

}  // namespace

MappingServer::MappingServer(const ServerOptions& options) : options_(options) {
  started_ = std::chrono::steady_clock::now();
  // Threads created from here on (DDS's receive threads, the query threads) inherit the short slice; the
  // pipeline's stages and the scan intake set the default back for themselves.
  if (options_.latency_slice_us < 0) throw std::invalid_argument("latency_slice_us must be >= 0");
  util::requestSchedulerSlice(std::chrono::microseconds(options_.latency_slice_us));
  store_ = std::make_unique<MapStore>(makeMap(options_.map));
  std::vector<std::unique_ptr<PipelineStage>> stages;
  if (options_.densify.method != "none")
    stages.push_back(std::make_unique<DensifyStage>(options_.densify, makeUpsampler(options_.densify)));
  stages.push_back(std::make_unique<OccupancyStage>(*store_, options_.update, updatePriority(options_)));
  if (options_.dense.method != "none") {
    dense_store_ = std::make_unique<DenseStore>(makeDenseLayer(options_.dense, options_.map.resolution));
    if (options_.dense.nice < 0 || options_.dense.nice > 19)
      throw std::invalid_argument("the dense layer's nice value must be 0..19");
    stages.push_back(std::make_unique<DenseStage>(*dense_store_, options_.dense.nice));
  }
  query_service_ = std::make_unique<QueryService>(*store_, options_.queries, dense_store_.get());
  pipeline_ = std::make_unique<Pipeline>(
      options_.pipeline, std::move(stages),
      [this](const ScanJob& j, ScanOutcome o, const std::string& why) { onOutcome(j, o, why); });
  listener_ = std::make_unique<Listener>(*this);
  // Real-time from here to the end: DDS's threads (they answer point and ray queries) and the query threads
  // inherit it; the intake and statistics threads drop it, and so does this thread at the end. The
  // pipeline's threads above were created before it.
  if (options_.realtime_priority < 0 || options_.realtime_priority > 99)
    throw std::invalid_argument("realtime_priority must be 0..99");
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
    dds.name = options_.server_id;
    node_ = std::make_unique<msg::DdsNode>(dds);
    auto* scans = node_->topic(msg::kScanTopic, msg::typeSupport<msg::ScanPubSubType>());
    auto* acks = node_->topic(msg::kScanAckTopic, msg::typeSupport<msg::ScanAckPubSubType>());
    auto* requests = node_->topic(msg::kQueryRequestTopic, msg::typeSupport<msg::QueryRequestPubSubType>());
    auto* replies = node_->topic(msg::kQueryReplyTopic, msg::typeSupport<msg::QueryReplyPubSubType>());
    auto* stats = node_->topic(msg::kStatisticsTopic, msg::typeSupport<msg::ServerStatisticsPubSubType>());
    ack_writer_ = node_->writer(acks, msg::kMessageWriterProfile);
    reply_writer_ = node_->writer(replies, msg::kMessageWriterProfile);
    stats_writer_ = node_->writer(stats, msg::kMessageWriterProfile);
    scan_reader_ = node_->reader(scans, msg::kScanReaderProfile, listener_.get());
    query_reader_ = node_->reader(requests, msg::kMessageReaderProfile, listener_.get());
  } catch (...) {
    util::setRealtimePriority(0);
    pipeline_->stop(false);
    throw;
  }
  ingest_thread_ = std::thread([this] {
    pthread_setname_np(pthread_self(), "dm-ingest");
    ingestLoop();
  });
  for (int i = 0; i < std::max(1, options_.query_threads); ++i)
    query_threads_.emplace_back([this] {
      pthread_setname_np(pthread_self(), "dm-query");
      queryLoop();
    });
  stats_thread_ = std::thread([this] {
    pthread_setname_np(pthread_self(), "dm-statistics");
    util::useBulkScheduling();
    statisticsLoop();
  });
  if (realtime) util::setRealtimePriority(0);
  spdlog::info("{} serving on DDS domain {} ({}): {} map at {} m, method {}, overflow policy {}",
               options_.server_id, options_.dds.domain, options_.dds.loopback ? "loopback" : "all interfaces",
               options_.map.backend, options_.map.resolution, update::toString(options_.update.method),
               toString(options_.pipeline.overflow));
}

MappingServer::~MappingServer() { stop(); }

void MappingServer::ingestLoop() {
  // Taking and converting scans is bulk work (the real-time priority and short slice are for queries).
  util::useBulkScheduling();
  msg::Scan m;
  dds::SampleInfo info;
  while (running_) {
    if (scan_reader_->take_next_sample(&m, &info) == ReturnCode_t::RETCODE_OK) {
      if (!info.valid_data) continue;
      std::string why;
      ScanJob job = toJob(m, why);
      if (why.empty()) why = validateScan(job, options_.limits);
      if (!why.empty()) {
        pipeline_->rejectAtDoor(job, why);
      } else {
        pipeline_->submit(std::move(job));
      }
      continue;
    }
    std::unique_lock lock(wake_mutex_);
    scans_ready_.wait_for(lock, 20ms);
  }
}

namespace {
/// Queries cheap enough to answer on DDS's receive thread (saves a thread hand-over, ~the round trip's
/// tail on a loaded machine); the rest go to the query threads.
bool answerInline(const msg::QueryRequest& rq) {
  return (rq.kind() == msg::QUERY_POINTS && rq.points().size() <= 3 * 20'000) || rq.kind() == msg::QUERY_RAY;
}
}  // namespace

void MappingServer::takeQueries(dds::DataReader* reader) {
  msg::QueryRequest rq;
  dds::SampleInfo info;
  while (reader->take_next_sample(&rq, &info) == ReturnCode_t::RETCODE_OK) {
    if (!info.valid_data) continue;
    if (answerInline(rq)) {
      msg::QueryReply rp = query_service_->answer(rq);
      reply_writer_->write(&rp);
    } else {
      {
        std::lock_guard lock(wake_mutex_);
        query_backlog_.push_back(std::move(rq));
      }
      queries_ready_.notify_one();
      rq = msg::QueryRequest();
    }
  }
}

void MappingServer::queryLoop() {
  for (;;) {
    msg::QueryRequest rq;
    {
      std::unique_lock lock(wake_mutex_);
      queries_ready_.wait(lock, [&] { return !query_backlog_.empty() || !queries_running_; });
      if (query_backlog_.empty()) return;
      rq = std::move(query_backlog_.front());
      query_backlog_.pop_front();
    }
    msg::QueryReply rp = query_service_->answer(rq);
    reply_writer_->write(&rp);
  }
}

void MappingServer::onOutcome(const ScanJob& job, ScanOutcome outcome, const std::string& why) {
  msg::ScanAck ack;
  ack.robot_id(job.robot_id);
  ack.seq(job.seq);
  ack.outcome(outcome == ScanOutcome::kInMap     ? msg::SCAN_APPLIED
              : outcome == ScanOutcome::kDropped ? msg::SCAN_DROPPED
                                                 : msg::SCAN_REJECTED);
  ack.message(why);
  ack.publish_ns(job.publish_ns);
  ack.done_ns(outcome == ScanOutcome::kInMap ? job.in_map_ns : msg::nowNs());
  ack.points_used(
      static_cast<std::uint32_t>(job.scan.points.size()) -
      std::min<std::uint32_t>(job.points_rejected, static_cast<std::uint32_t>(job.scan.points.size())));
  ack.points_rejected(job.points_rejected);
  ack.map_version(job.map_version);
  if (ack_writer_ != nullptr) ack_writer_->write(&ack);
}

msg::ServerStatistics MappingServer::statistics() const {
  msg::ServerStatistics s;
  s.server_id(options_.server_id);
  s.stamp_ns(msg::nowNs());
  s.uptime_s(std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count());
  for (const auto& [id, c] : pipeline_->robotCounters()) {
    msg::RobotStatistics r;
    r.robot_id(id);
    r.received(c.received);
    r.processed(c.processed);
    r.dropped(c.dropped);
    r.rejected(c.rejected);
    r.points_rejected(c.points_rejected);
    r.queue_depth(static_cast<std::uint32_t>(c.queue_depth));
    r.queue_capacity(static_cast<std::uint32_t>(c.queue_capacity));
    r.last_sequence(c.last_seq);
    s.robots().push_back(std::move(r));
  }
  for (const StageCounters& c : pipeline_->stageCounters()) {
    msg::StageStatistics st;
    st.name(c.name);
    st.processed(c.processed);
    st.dropped(c.dropped);
    st.queue_depth(static_cast<std::uint32_t>(c.queue_depth));
    st.latency_p50_ms(c.latency.p50_ms);
    st.latency_p99_ms(c.latency.p99_ms);
    st.latency_max_ms(c.latency.max_ms);
    s.stages().push_back(std::move(st));
  }
  // Pseudo-stages: answering queries inside the server (lock waits included), how long a scan's publish
  // (or a clear/reset) holds readers out of the map, and how long reads waited for it.
  auto addPseudoStage = [&](const char* name, std::uint64_t processed, const LatencySummary& l) {
    msg::StageStatistics st;
    st.name(name);
    st.processed(processed);
    st.latency_p50_ms(l.p50_ms);
    st.latency_p99_ms(l.p99_ms);
    st.latency_max_ms(l.max_ms);
    s.stages().push_back(std::move(st));
  };
  addPseudoStage("queries", query_service_->answered() + query_service_->failed(), query_service_->latency());
  const LatencySummary hold = store_->exclusiveHold(), wait = store_->readWait();
  addPseudoStage("map-publish", hold.count, hold);  // count: samples in the latency window
  addPseudoStage("map-read-wait", wait.count, wait);
  // Cheap map figures only (the periodic message must not hold the map for a full iteration).
  store_->read([&](const map::OccupancyMap& m, std::uint64_t version) {
    s.map_stats().backend(m.backendName());
    s.map_stats().resolution(m.resolution());
    s.map_stats().map_version(version);
    s.map_stats().memory_bytes(m.memoryBytes());
    return 0;
  });
  const LatencySummary lat = pipeline_->publishToMapLatency();
  s.publish_to_map_p50_ms(lat.p50_ms);
  s.publish_to_map_p99_ms(lat.p99_ms);
  s.queries_answered(query_service_->answered());
  s.queries_failed(query_service_->failed());
  s.resident_bytes(residentBytes());
  return s;
}

void MappingServer::statisticsLoop() {
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
    msg::ServerStatistics s = statistics();
    stats_writer_->write(&s);
    std::uint64_t processed = 0, received = 0, dropped = 0, rejected = 0;
    for (const auto& r : s.robots()) {
      processed += r.processed();
      received += r.received();
      dropped += r.dropped();
      rejected += r.rejected();
    }
    const std::uint64_t activity = processed + rejected + dropped + s.queries_answered() + s.queries_failed();
    if (activity != last_logged) {  // log while something happens, stay quiet when idle
      std::string stages;
      for (const auto& st : s.stages()) {
        stages +=
            fmt::format("; {} p50 {:.2f} p99 {:.2f} ms", st.name(), st.latency_p50_ms(), st.latency_p99_ms());
        if (st.dropped() > 0) stages += fmt::format(" ({} scans skipped: behind)", st.dropped());
      }
      spdlog::info(
          "{} robots: {} scans received, {} in map, {} dropped, {} rejected; publish-to-map p50 {:.1f} ms "
          "p99 {:.1f} ms; map {:.1f} MB; {} queries{}",
          s.robots().size(), received, processed, dropped, rejected, s.publish_to_map_p50_ms(),
          s.publish_to_map_p99_ms(), static_cast<double>(s.map_stats().memory_bytes()) / 1e6,
          s.queries_answered(), stages);
      last_logged = activity;
    }
  }
}

void MappingServer::stop() {
  std::lock_guard lock(stop_mutex_);
  if (stopped_) return;
  spdlog::info("{}: shutting down ({} queued scans {})", options_.server_id, pipeline_->inFlight(),
               options_.drain_on_exit ? "to finish" : "to drop");
  running_ = false;
  scans_ready_.notify_all();
  stats_wake_.notify_all();
  pipeline_->stop(options_.drain_on_exit);
  if (ingest_thread_.joinable()) ingest_thread_.join();
  store_->writerStopped();
  if (!options_.save_on_exit.empty()) {
    try {
      store_->read([&](const map::OccupancyMap& m, std::uint64_t) {
        map::saveMap(m, options_.save_on_exit);
        return 0;
      });
      spdlog::info("saved the map to {}", options_.save_on_exit);
    } catch (const std::exception& e) {
      spdlog::error("could not save the map on exit: {}", e.what());
    }
  }
  if (stats_thread_.joinable()) stats_thread_.join();
  if (stats_writer_ != nullptr) {
    msg::ServerStatistics s = statistics();
    stats_writer_->write(&s);
  }
  stopped_ = true;
  {
    std::lock_guard lock(wake_mutex_);
    queries_running_ = false;  // the threads finish the backlog first
  }
  queries_ready_.notify_all();
  for (auto& t : query_threads_) {
    if (t.joinable()) t.join();
  }
  node_->close();
}

}  // namespace densemap::server
