// densemap-replay: publishes any scan source as one or several robots at a rate, reports what the server
// acknowledged, and (with --query-clients) measures query round trips while the scans stream in.
#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <fstream>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <random>
#include <set>
#include <thread>

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "densemap/cli/cli_common.h"
#include "densemap/cli/common_options.h"
#include "densemap/cli/option_cli.h"
#include "densemap/client/query_client.h"
#include "densemap/client/ros2_player.h"
#include "densemap/client/scan_publisher.h"
#include "densemap/client/scan_resender.h"
#include "densemap/client/server_join.h"
#include "densemap/densify/range_image.h"
#include "densemap/msg/dds_options_cli.h"
#include "densemap/msg/peer_topic.h"
#include "densemap/ros2/bag_reader.h"
#include "densemap/sources/open_source.h"
#include "densemap/util/percentile.h"
#include "densemap/util/realtime_priority.h"
#include "densemap/util/scheduler_slice.h"

using namespace densemap;
using Clock = std::chrono::steady_clock;

namespace {

/// --scan-log: one JSON object per line, written through at once so a killed robot's log is complete.
class ScanLog {
 public:
  explicit ScanLog(const std::string& path) {
    if (path.empty()) return;
    file_.reset(std::fopen(path.c_str(), "a"));
    if (!file_) throw std::runtime_error("cannot open --scan-log " + path + " for appending");
  }
  bool enabled() const { return file_ != nullptr; }
  void write(const nlohmann::json& event) {
    const std::string line = event.dump() + "\n";
    std::lock_guard lock(mutex_);
    std::fwrite(line.data(), 1, line.size(), file_.get());
    std::fflush(file_.get());
  }

 private:
  struct Close {
    void operator()(std::FILE* f) const { std::fclose(f); }
  };
  std::unique_ptr<std::FILE, Close> file_;
  std::mutex mutex_;
};

}  // namespace

using util::percentile;

/// densemap-replay --ros2 when no subscriber (a densemap-server --ros2, or any ROS 2 node) read the clouds.
int ros2NobodyReads(const client::JoinContext& context, const client::Ros2PlayResult& r, double wait_s) {
  spdlog::error(
      "{} (nothing was published; a ROS 2 server is densemap-server --ros2, whose --cloud-topic must "
      "be this topic)",
      client::noServerMessage(context, std::chrono::milliseconds(static_cast<long>(wait_s * 1000)),
                              "no reader of " + r.unread_topic));
  return 1;
}

int main(int argc, char** argv) {
  CLI::App app{"densemap-replay: publish scans from a source as robots to a densemap-server over DDS"};
  msg::DdsOptions dds;
  sources::SourceSelection source;
  std::string prefix = "robot", offset_text = "0,0,0", summary_json, log_level = "info";
  int robots = 1, loops = 1, query_clients = 0, first_robot = 0, beam_step = 0;
  std::size_t max_scans = 0;
  double rate = 10.0, speed = 1.0, query_radius = 20.0, query_rate = 0.0, duration_s = 10.0;
  std::string center_text = "0,0,0", query_kind = "points";
  std::size_t query_points = 1000;
  app.set_config("--config", "", "TOML file with any of these options (flags override it)");
  auto dds_table = msg::ddsOptions(dds);
  auto logging_table = cli::loggingOptions(log_level);
  auto source_table = sources::sourceOptionTable(source);
  client::JoinOptions join_options;
  auto join_table = client::joinOptions(join_options);
  cli::addToApp(app, {&source_table, &dds_table, &join_table, &logging_table});
  app.add_option(
         "--keep-every-nth-beam", beam_step,
         "send every n-th beam of each scan (4: a 16-beam LiDAR from a 64-beam one), with that geometry")
      ->capture_default_str();
  app.add_option("--robots", robots,
                 "robots publishing the source at once (0: only run --query-clients for --duration)")
      ->capture_default_str()
      ->check(CLI::Range(0, 1000));
  auto* prefix_option =
      app.add_option(
             "--robot-prefix", prefix,
             "robot ids are PREFIX-0, PREFIX-1, ... (secure mode: the identity's name unless given; a "
             "robot identity may send only as NAME and NAME-<k>)")
          ->capture_default_str();
  app.add_option("--robot-offset", offset_text, "robot k's scans are shifted by k times this x,y,z (metres)")
      ->capture_default_str();
  app.add_option("--rate", rate, "scans per second per robot (0: as fast as the server takes them)")
      ->capture_default_str();
  app.add_option("--speed", speed, "multiplies the rate (2: twice as fast)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--first-robot", first_robot, "index of the first robot (ids and offsets count from it)")
      ->capture_default_str();
  app.add_option("--max-scans", max_scans,
                 "stop each robot after this many scans (0: the whole range x --loops)")
      ->capture_default_str();
  app.add_option("--loops", loops, "replay the range this many times (sequence numbers keep counting)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--query-clients", query_clients, "query clients sending point queries during the replay")
      ->capture_default_str();
  app.add_option("--query-points", query_points, "points per query")->capture_default_str();
  app.add_option(
         "--query-kind", query_kind,
         "what the query clients ask: 'points' (--query-points cells), 'box' (the cells of a 4 m cube, "
         "at most --query-points of them) or 'ray' (a cast of up to 30 m)")
      ->capture_default_str()
      ->check(CLI::IsMember({"points", "box", "ray"}));
  app.add_option("--duration", duration_s, "with --robots 0: seconds the query clients run")
      ->capture_default_str();
  app.add_option("--query-center", center_text, "with --robots 0: query points are drawn around x,y,z")
      ->capture_default_str();
  app.add_option("--query-rate", query_rate,
                 "queries per second per client (0: back to back, for throughput)")
      ->capture_default_str();
  app.add_option("--query-radius", query_radius, "query points are drawn within this many metres of robot 0")
      ->capture_default_str();
  int latency_slice_us = 100;
  app.add_option("--latency-slice-us", latency_slice_us,
                 "with query clients: scheduler slice of this process's threads in microseconds (Linux >= "
                 "6.12 wakes short-slice threads sooner; 0: the kernel's default)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  int realtime_priority = 0;
  app.add_option("--realtime-priority", realtime_priority,
                 "with query clients: SCHED_FIFO priority (1-99) of their threads and this process's DDS "
                 "threads (needs root, CAP_SYS_NICE or `ulimit -r`); 0: normal scheduling")
      ->capture_default_str()
      ->check(CLI::Range(0, 99));
  app.add_option("--summary-json", summary_json, "write a JSON summary (counts, latencies) to this file");
  std::string scan_log_path;
  app.add_option("--scan-log", scan_log_path,
                 "append one JSON line per scan sent, refused by DDS and acknowledged, as it happens (kept "
                 "when the process is killed; the cross-host test reads it)");
  bool resume = true;
  app.add_flag("--resume,!--no-resume", resume,
               "go on numbering after the scans the server has on disk already (its robot progress), and "
               "resend what it lost when it restarts")
      ->capture_default_str();
  bool ros2_mode = false;
  app.add_flag(
      "--ros2", ros2_mode,
      "play as a ROS 2 robot: a bag's recorded messages unchanged (topics, types, QoS, timing; --speed, "
      "--rate 0 for no timing), any other source as PointCloud2 on --cloud-topic (default /cloud_in) "
      "+ /tf in --frame-id");
  if (const auto rc = cli::parse(app, argc, argv, {&source_table, &dds_table, &join_table, &logging_table}))
    return *rc;
  cli::setupLogging(log_level);
  const double wait_s = join_options.wait_s;
  if (ros2_mode && ros2::isBag(source.source)) {
    try {
      const auto bag = ros2::openBag(source.source);
      spdlog::info("playing {} as ROS 2", bag->describe());
      client::Ros2PlayOptions o;
      o.speed = speed;
      o.as_fast_as_possible = app.get_option("--rate")->count() > 0 && rate == 0.0;
      o.wait_s = wait_s;
      dds.name = "densemap-replay";
      msg::DdsNode node(dds);
      const client::JoinContext context = client::joinContext(dds, node, "a subscriber to the bag's clouds");
      o.where = context.where;
      const client::Ros2PlayResult r = client::playBag(*bag, node, o);
      if (!r.unread_topic.empty()) return ros2NobodyReads(context, r, wait_s);
      std::printf("played %zu messages (%zu clouds) in %.2f s\n", r.messages, r.clouds, r.seconds);
      return 0;
    } catch (const std::exception& e) {
      spdlog::error("{}", e.what());
      return 1;
    }
  }

  try {
    float ox = 0, oy = 0, oz = 0;
    if (std::sscanf(offset_text.c_str(), "%f,%f,%f", &ox, &oy, &oz) != 3) {
      throw std::invalid_argument("--robot-offset must be x,y,z");
    }
    const Eigen::Vector3d offset(ox, oy, oz);
    // Read every scan first, so file reading never slows the publishing rate down.
    std::vector<io::Scan> data;
    std::string described = "none (query clients only)";
    if (robots > 0) {
      auto src = sources::openSource(source.source, source.options);
      const auto range = cli::parseScanRange(source.scans, src->size());
      described = src->describe();
      spdlog::info("source: {}", described);
      cli::Progress progress("reading", range.last - range.first + 1);
      for (std::size_t i = range.first; i <= range.last; ++i) {
        data.push_back(src->read(i));
        if (beam_step > 1) {
          // A sparse LiDAR from a dense one: every n-th beam of the scan's range image (its geometry, or the
          // KITTI HDL-64E layout), sent with the sparse geometry so a server can densify it.
          io::Scan& s = data.back();
          const auto image = densify::keepEveryNthRow(
              densify::project(s.sensorPoints(), s.lidar.value_or(io::LidarGeometry{})), beam_step);
          s.points = densify::toPoints(image);
          s.frame = io::PointFrame::kSensor;
          s.lidar = image.geometry;
        }
        progress.step(data.size());
      }
    }

    dds.name = "densemap-replay";
    if (ros2_mode) {
      client::Ros2PlayOptions o;
      o.rate = rate * speed;
      o.wait_s = wait_s;
      if (!source.options.frames.cloud_topic.empty()) o.cloud_topic = source.options.frames.cloud_topic;
      o.fixed_frame = source.options.frames.fixed_frame;
      msg::DdsNode node(dds);
      const client::JoinContext context = client::joinContext(dds, node, "a subscriber to " + o.cloud_topic);
      o.where = context.where;
      const client::Ros2PlayResult r = client::playScans(data, node, o);
      if (!r.unread_topic.empty()) return ros2NobodyReads(context, r, wait_s);
      std::printf("published %zu clouds with their transforms in %.2f s\n", r.clouds, r.seconds);
      return 0;
    }
    // Before the DDS participant: its receive threads and the query clients inherit the slice.
    if (query_clients > 0) util::requestSchedulerSlice(std::chrono::microseconds(latency_slice_us));
    // Real-time likewise, until the query threads exist (the robots' threads are created after it ends).
    const bool realtime =
        query_clients > 0 && realtime_priority > 0 && util::setRealtimePriority(realtime_priority);
    if (query_clients > 0 && realtime_priority > 0 && !realtime) {
      spdlog::warn(
          "--realtime-priority {}: this process may not use SCHED_FIFO; the query clients run at "
          "normal priority. To allow it: {}",
          realtime_priority, util::realtimePriorityHint());
    }
    ScanLog scan_log(scan_log_path);
    // From here to matched (and to the server's first statistics seen): the time a new robot needs to join,
    // authentication and the permissions handshake included in secure mode.
    const auto joined_from = std::chrono::steady_clock::now();
    // Made again, with a new participant, when a secure join stalls (see --rejoin-after): the publisher,
    // its observer and the ids go with the node.
    std::optional<msg::DdsNode> node;
    std::set<std::string> ids;
    // Only with robots: a query client's identity may not publish scans (secure mode refuses the writer).
    std::optional<client::ScanPublisher> publisher;
    const auto join = [&] {
      publisher.reset();
      node.reset();
      node.emplace(dds);
      // A robot identity's permissions name its scan topics: NAME and NAME-<k> (tools/make-security.sh).
      if (node->secure() && prefix_option->count() == 0) prefix = node->identity().name;
      ids.clear();
      for (int k = 0; k < robots; ++k) ids.insert(prefix + "-" + std::to_string(first_robot + k));
      if (robots == 0) return;
      try {
        publisher.emplace(*node, std::vector<std::string>(ids.begin(), ids.end()));
      } catch (const msg::DdsError& e) {
        if (!node->secure()) throw;
        throw std::runtime_error(fmt::format(
            "{}. In secure mode identity '{}' publishes scans only as robot ids '{}' and '{}-<k>': leave out "
            "--robot-prefix (it defaults to the identity's name), or use a robot identity",
            e.what(), node->identity().name, node->identity().name, node->identity().name));
      }
      if (scan_log.enabled()) {
        // Acknowledgements come on this process's robots' own topics; the check keeps the log to them anyway.
        publisher->setAckObserver([&scan_log, &ids](const msg::ScanAck& a) {
          if (!ids.count(a.robot_id())) return;
          scan_log.write({{"event", "ack"},
                          {"robot", a.robot_id()},
                          {"seq", a.seq()},
                          {"outcome", client::toString(a.outcome())},
                          {"durable", a.durable()},
                          {"publish_ns", a.publish_ns()},
                          {"done_ns", a.done_ns()}});
        });
      }
    };
    join();
    const auto wait = join_options.wait();
    int rejoins = 0;
    const auto join_wait = wait;
    const auto attempt = join_options.attempt(node->secure());
    std::vector<std::unique_ptr<client::QueryClient>> query_clients_v;
    const auto add_query_client = [&] {
      const auto c = std::to_string(query_clients_v.size());
      query_clients_v.push_back(std::make_unique<client::QueryClient>(
          *node, client::clientIdOf(*node, "replay-" + std::to_string(::getpid()) + "-q" + c, "q" + c)));
    };
    if (publisher) {
      const client::JoinContext context = client::joinContext(
          dds, *node,
          fmt::format("a densemap-server to read the scans of {} robot(s) on {} ...", ids.size(),
                      node->topicName(msg::peerTopicOf(msg::kScanTopic, *ids.begin()))));
      const auto joined = client::joinServer([&]() -> client::ScanPublisher& { return *publisher; }, join,
                                             join_wait, attempt, &context);
      rejoins = joined.rejoins;
      if (!joined.joined) throw std::runtime_error(client::noServerMessage(context, join_wait, joined.state));
    } else if (query_clients > 0) {
      // Queries only: the first query client joins for the participant (made again as a robot's would be).
      add_query_client();
      const client::JoinContext context = client::joinContext(
          dds, *node,
          "a densemap-server answering queries on " + node->topicName(msg::kQueryRequestTopic) +
              " (secure: an identity whose role may query, e.g. client-1)");
      const auto joined =
          client::joinServer([&]() -> client::QueryClient& { return *query_clients_v.front(); },
                             [&] {
                               query_clients_v.clear();
                               join();
                               add_query_client();
                             },
                             join_wait, attempt, &context);
      rejoins = joined.rejoins;
      if (!joined.joined) throw std::runtime_error(client::noServerMessage(context, join_wait, joined.state));
    }
    const auto since_join = [&joined_from](std::chrono::steady_clock::time_point t) {
      return std::chrono::duration<double, std::milli>(t - joined_from).count();
    };
    double matched_ms = since_join(publisher ? publisher->matchedAt().value_or(joined_from) : joined_from);
    double server_ready_ms = since_join(std::chrono::steady_clock::now());
    // The server counts per robot id over its lifetime: report this run's part.
    const auto before = publisher ? publisher->lastStatistics() : std::nullopt;
    const client::RobotTotals base = before ? client::totalsFor(*before, ids) : client::RobotTotals{};

    // Query clients: point queries around robot 0's latest position, timed end to end.
    std::atomic<bool> replaying{true};
    std::array<std::atomic<float>, 3> robot0{};
    {
      float cx = 0, cy = 0, cz = 0;
      if (std::sscanf(center_text.c_str(), "%f,%f,%f", &cx, &cy, &cz) != 3) {
        throw std::invalid_argument("--query-center must be x,y,z");
      }
      robot0[0] = cx;
      robot0[1] = cy;
      robot0[2] = cz;
    }
    std::mutex query_mutex;
    std::vector<double> query_ms;
    std::atomic<std::uint64_t> query_failures{0}, query_busy{0};
    std::vector<std::thread> query_threads;
    // The rest join on a participant the server has matched already.
    while (static_cast<int>(query_clients_v.size()) < query_clients) {
      add_query_client();
      if (!query_clients_v.back()->waitForServer(wait)) {
        const client::JoinContext context = client::joinContext(
            dds, *node, "a densemap-server answering queries on " + node->topicName(msg::kQueryRequestTopic));
        throw std::runtime_error(client::noServerMessage(context, wait, query_clients_v.back()->joinState()));
      }
    }
    if (!publisher) matched_ms = server_ready_ms = since_join(std::chrono::steady_clock::now());
    for (int c = 0; c < query_clients; ++c) {
      query_threads.emplace_back([&, c] {
        std::mt19937 rng(static_cast<unsigned>(c + 1));
        std::uniform_real_distribution<float> u(-static_cast<float>(query_radius),
                                                static_cast<float>(query_radius));
        std::uniform_real_distribution<float> uz(-2.0f, 3.0f);
        std::vector<double> mine;
        auto next = Clock::now();
        while (replaying) {
          if (query_rate > 0) {
            next +=
                std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / query_rate));
            std::this_thread::sleep_until(next);
          }
          msg::QueryRequest rq;
          const std::array<float, 3> around{robot0[0] + u(rng), robot0[1] + u(rng), robot0[2] + uz(rng)};
          if (query_kind == "box") {
            rq.kind(msg::QUERY_BOX);
            for (std::size_t a = 0; a < 3; ++a) {
              rq.box_min()[a] = around[a] - 2.0f;
              rq.box_max()[a] = around[a] + 2.0f;
            }
            rq.limit(static_cast<std::uint32_t>(query_points));
          } else if (query_kind == "ray") {
            rq.kind(msg::QUERY_RAY);
            const float yaw = u(rng) / static_cast<float>(query_radius) * 3.14159265f;
            rq.ray_origin({robot0[0].load(), robot0[1].load(), robot0[2].load()});
            rq.ray_direction({std::cos(yaw), std::sin(yaw), -0.05f});
            rq.max_range(30.0f);
          } else {
            rq.kind(msg::QUERY_POINTS);
            rq.points().resize(3 * query_points);
            for (std::size_t i = 0; i < query_points; ++i) {
              rq.points()[3 * i] = robot0[0] + u(rng);
              rq.points()[3 * i + 1] = robot0[1] + u(rng);
              rq.points()[3 * i + 2] = robot0[2] + uz(rng);
            }
          }
          const auto t0 = Clock::now();
          try {
            const auto r = query_clients_v[static_cast<std::size_t>(c)]->call(rq, std::chrono::seconds(5));
            if (r.status() == msg::STATUS_BUSY) {
              ++query_busy;  // answered, in time: the server's backlog was full
              continue;
            }
            if (r.status() != msg::STATUS_OK) ++query_failures;
          } catch (const std::exception&) {
            ++query_failures;
            continue;
          }
          mine.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
        }
        std::lock_guard lock(query_mutex);
        query_ms.insert(query_ms.end(), mine.begin(), mine.end());
      });
    }

    if (realtime) util::setRealtimePriority(0);

    // One thread per robot, each on its own schedule, started a fraction of a period apart.
    std::size_t per_robot = data.size() * static_cast<std::size_t>(loops);
    if (max_scans > 0) per_robot = std::min(per_robot, max_scans);
    const std::uint64_t total = per_robot * static_cast<std::size_t>(robots);
    const double period_s = rate > 0 ? 1.0 / (rate * speed) : 0.0;
    std::atomic<std::uint64_t> sent{0}, refused{0};
    cli::Progress progress("publishing", total);
    const auto t_start = Clock::now();
    std::vector<std::thread> robot_threads;
    std::mutex resend_mutex;
    client::ResendCounts resends;
    for (int k = 0; k < robots; ++k) {
      robot_threads.emplace_back([&, k] {
        const int index = first_robot + k;  // robot index: its id and its offset
        const std::string id = prefix + "-" + std::to_string(index);
        const auto start = t_start + std::chrono::duration_cast<Clock::duration>(
                                         std::chrono::duration<double>(period_s * k / std::max(1, robots)));
        auto scan_of = [&, index](std::uint64_t n) {
          io::Scan scan = data[n % data.size()];
          if (index > 0) {
            scan.pose.pretranslate(offset * index);
            if (scan.frame == io::PointFrame::kWorld) {
              for (auto& p : scan.points) p += (offset * index).cast<float>();
            }
          }
          return scan;
        };
        client::ScanResender resender(*publisher, id, scan_of);
        // The server says which of this robot's scans it has on disk already: a robot that restarts goes on
        // numbering after them (and sends its per-robot count from there), instead of repeating them.
        // Every server publishes its progress as soon as its scan reader exists, but the progress topic
        // may match a while after the scans did (seconds over a slow network): waiting only briefly
        // would start again at 0 and send nothing but duplicates. Bounded for servers without it.
        const std::uint64_t first =
            resume ? resender.resumeFrom(0, std::numeric_limits<std::uint64_t>::max() / 2,
                                         std::min(wait, std::chrono::milliseconds(10000)))
                   : 0;
        for (std::uint64_t n = first; n < first + per_robot; ++n) {
          if (period_s > 0) {
            std::this_thread::sleep_until(
                start + std::chrono::duration_cast<Clock::duration>(
                            std::chrono::duration<double>(period_s * static_cast<double>(n - first))));
          }
          if (k == 0) {
            const Eigen::Vector3d t = scan_of(n).pose.translation();
            for (int a = 0; a < 3; ++a) robot0[static_cast<std::size_t>(a)] = static_cast<float>(t[a]);
          }
          const std::int64_t t_ns = msg::nowNs();
          // Refused by DDS (a server gone, its lease not over yet): retried, with resends after a restart.
          const bool ok = resender.send(n, Clock::now() + wait);
          if (ok) {
            progress.step(++sent);
          } else {
            ++refused;
          }
          if (scan_log.enabled()) {
            scan_log.write({{"event", ok ? "sent" : "refused"}, {"robot", id}, {"seq", n}, {"t_ns", t_ns}});
          }
        }
        if (!resender.settle(Clock::now() + wait)) {
          spdlog::error("{}: {} scans not acknowledged within {} s", id, resender.outstanding(), wait_s);
        }
        std::lock_guard lock(resend_mutex);
        resends.restarts_seen = std::max(resends.restarts_seen, resender.counts().restarts_seen);
        resends.resent += resender.counts().resent;
        resends.held += resender.counts().held;
        resends.skipped += resender.counts().skipped;
      });
    }
    {
      // One line every 10 s while the robots send and settle: a stall never looks like a hang.
      std::mutex report_mutex;
      std::condition_variable report_wake;
      bool robots_done = false;
      std::thread reporter([&] {
        std::unique_lock lock(report_mutex);
        while (!report_wake.wait_for(lock, std::chrono::seconds(10), [&] { return robots_done; })) {
          const std::uint64_t acked = publisher ? publisher->acks(ids).total() : 0;
          spdlog::info("sent {} of {} scans, {} acknowledged, {} waiting for an acknowledgement{}",
                       sent.load(), total, acked, sent.load() - std::min<std::uint64_t>(sent.load(), acked),
                       refused.load() > 0 ? fmt::format(", {} sends refused by DDS (retried)", refused.load())
                                          : std::string());
        }
      });
      for (auto& t : robot_threads) t.join();
      {
        std::lock_guard lock(report_mutex);
        robots_done = true;
      }
      report_wake.notify_all();
      reporter.join();
    }
    if (robots == 0) std::this_thread::sleep_for(std::chrono::duration<double>(duration_s));
    const double publish_s = std::chrono::duration<double>(Clock::now() - t_start).count();
    const client::AckCounts acks =
        publisher ? publisher->waitForAcks(ids, sent, std::chrono::milliseconds(1000)) : client::AckCounts{};
    replaying = false;
    for (auto& t : query_threads) t.join();
    const double total_s = std::chrono::duration<double>(Clock::now() - t_start).count();
    // The server's own count, from its statistics (published once a second).
    const auto stats =
        publisher ? publisher->waitForStatistics(ids, sent + base.processed + base.dropped + base.rejected,
                                                 std::chrono::milliseconds(3000))
                  : std::nullopt;
    client::RobotTotals server = stats ? client::totalsFor(*stats, ids) : client::RobotTotals{};
    server.processed -= std::min(server.processed, base.processed);
    server.dropped -= std::min(server.dropped, base.dropped);
    server.rejected -= std::min(server.rejected, base.rejected);
    const auto lat = publisher ? publisher->latenciesMs(ids) : std::vector<double>{};

    nlohmann::json j = {{"source", described},
                        {"robots", robots},
                        {"robot_ids", std::vector<std::string>(ids.begin(), ids.end())},
                        {"rate_hz", rate * speed},
                        {"scans_sent", sent.load()},
                        {"scans_refused_by_dds", refused.load()},
                        {"scans_acknowledged", acks.total()},
                        {"scans_processed", server.processed},
                        {"scans_dropped", server.dropped},
                        {"scans_rejected", server.rejected},
                        {"acks_applied", acks.applied},
                        {"acks_dropped", acks.dropped},
                        {"acks_rejected", acks.rejected},
                        {"acks_duplicate", acks.duplicate},
                        {"acks_durable", acks.durable},
                        {"server_restarts_seen", resends.restarts_seen},
                        {"scans_resent", resends.resent},
                        {"scans_held_unacknowledged", resends.held},
                        {"resumed_after_durable", resends.skipped},
                        {"latency_p50_ms", percentile(lat, 0.5)},
                        {"latency_p99_ms", percentile(lat, 0.99)},
                        {"latency_max_ms", percentile(lat, 1.0)},
                        {"latencies_ms", lat},  // raw, so a load test can pool robots
                        {"publish_seconds", publish_s},
                        {"total_seconds", total_s},
                        {"server_statistics", stats.has_value()},
                        {"secure", node->secure()},
                        {"rejoins", rejoins},
                        {"matched_ms", matched_ms},
                        {"server_ready_ms", server_ready_ms}};
    if (stats) {
      for (const auto& st : stats->stages()) {
        j["server_stage_" + st.name() + "_p50_ms"] = st.latency_p50_ms();
        j["server_stage_" + st.name() + "_p99_ms"] = st.latency_p99_ms();
      }
    }
    if (query_clients > 0) {
      const double points = static_cast<double>(query_ms.size() * query_points);
      j["query_clients"] = query_clients;
      j["query_kind"] = query_kind;
      j["query_points"] = query_points;
      j["query_rate_hz"] = query_rate;
      j["queries"] = query_ms.size();
      j["query_failures"] = query_failures.load();
      j["query_busy"] = query_busy.load();
      j["query_p50_ms"] = percentile(query_ms, 0.5);
      j["query_p99_ms"] = percentile(query_ms, 0.99);
      j["query_points_per_s"] = points / std::max(1e-9, total_s);
      j["query_latencies_ms"] = query_ms;  // raw, so a load test can pool clients of one kind
    }
    std::printf(
        "sent %llu scans for %d robot(s) in %.1f s; acknowledged %llu (applied %llu, dropped %llu, rejected "
        "%llu)\n",
        static_cast<unsigned long long>(sent.load()), robots, publish_s,
        static_cast<unsigned long long>(acks.total()), static_cast<unsigned long long>(acks.applied),
        static_cast<unsigned long long>(acks.dropped), static_cast<unsigned long long>(acks.rejected));
    std::printf(
        "server statistics: %llu processed, %llu dropped, %llu rejected; publish-to-map latency p50 %.1f ms, "
        "p99 %.1f ms\n",
        static_cast<unsigned long long>(server.processed), static_cast<unsigned long long>(server.dropped),
        static_cast<unsigned long long>(server.rejected), percentile(lat, 0.5), percentile(lat, 0.99));
    if (query_clients > 0) {
      std::printf(
          "%s queries: %zu x %zu points from %d clients, round trip p50 %.2f ms, p99 %.2f ms, %.0f points/s, "
          "%llu failed, %llu busy\n",
          query_kind.c_str(), query_ms.size(), query_points, query_clients, percentile(query_ms, 0.5),
          percentile(query_ms, 0.99), j["query_points_per_s"].get<double>(),
          static_cast<unsigned long long>(query_failures.load()),
          static_cast<unsigned long long>(query_busy.load()));
    }
    if (!summary_json.empty()) {
      std::ofstream f(summary_json);
      if (!f) throw std::runtime_error("cannot write " + summary_json);
      f << j.dump(2) << "\n";
    }
    if (resends.restarts_seen > 0 || resends.skipped > 0) {
      std::printf(
          "the server restarted %llu time(s): %llu scans sent again, %llu found on its disk unacknowledged; "
          "numbering went on after %llu scans on its disk already\n",
          static_cast<unsigned long long>(resends.restarts_seen),
          static_cast<unsigned long long>(resends.resent), static_cast<unsigned long long>(resends.held),
          static_cast<unsigned long long>(resends.skipped));
    }
    if (acks.total() + resends.held < sent) {
      spdlog::error("{} scans were not acknowledged within {} s", sent - acks.total(), wait_s);
      return 3;
    }
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
  return 0;
}
