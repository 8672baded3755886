// densemap-ros2-bench: the same recording sent to an in-process server as densemap scans (its native DDS
// edge) and as ROS 2 clouds + TF (its ROS 2 edge, `ros2 bag play` style), alternating, several rounds:
// publish-to-map p50/p99 at the recorded rate, the time clouds wait for TF, and the ingest rate when
// sent as fast as possible. Prints one line per run and the medians with their ratios.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <thread>

#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>

#include "densemap/cli/cli_common.h"
#include "densemap/client/ros2_player.h"
#include "densemap/client/scan_publisher.h"
#include "densemap/client/server_join.h"
#include "densemap/ros2/bag_scan_source.h"
#include "densemap/ros2/message_codec.h"
#include "densemap/server/dds_edge/dds_edge.h"
#include "densemap/server/map_service.h"
#include "densemap/server/ros2_edge/ros2_edge.h"
#include "densemap/util/percentile.h"

using namespace densemap;
using Clock = std::chrono::steady_clock;

namespace {

struct Run {
  std::string kind;  // "densemap" or "ros2"
  bool fast = false;
  std::size_t sent = 0, mapped = 0;
  double seconds = 0;  // first publish to last in the map
  server::LatencySummary publish_to_map, tf_wait;
};

/// When the service had `n` scans in its map (polled every 2 ms on its own thread), or the timeout.
class MappedWatch {
 public:
  MappedWatch(server::MapService& s, std::size_t n, double timeout_s)
      : thread_([this, &s, n, timeout_s] {
          const auto until = Clock::now() + std::chrono::duration<double>(timeout_s);
          while (Clock::now() < until && s.statistics().totals().processed < n)
            std::this_thread::sleep_for(std::chrono::milliseconds(2));
          done_ = Clock::now();
        }) {}
  Clock::time_point done() {
    if (thread_.joinable()) thread_.join();
    return done_;
  }
  ~MappedWatch() { done(); }

 private:
  Clock::time_point done_{};
  std::thread thread_;
};

server::ServiceOptions serviceOptions() {
  server::ServiceOptions o;
  o.map_dir = (std::filesystem::temp_directory_path() / "densemap-ros2-bench-maps").string();
  o.data_dir = o.map_dir + "-data";
  std::filesystem::remove_all(o.data_dir);  // each server of the bench starts from an empty map
  return o;
}

Run runNative(const std::vector<io::Scan>& scans, int domain, bool fast, double rate) {
  Run r;
  r.kind = "densemap";
  r.fast = fast;
  server::MapService service(serviceOptions());
  server::dds_edge::DdsEdgeOptions eo;
  eo.dds.domain = domain;
  eo.dds.loopback = true;
  eo.duplicate_check_s = 0;
  eo.statistics_period_s = 0;
  server::dds_edge::DdsEdge edge(service, eo);
  msg::DdsOptions d = eo.dds;
  d.name = "bench-robot";
  msg::DdsNode node(d);
  client::ScanPublisher pub(node, {"robot-0"});
  const client::JoinContext context =
      client::joinContext(d, node, "this bench's own server reading densemap/scans/robot_h0");
  const auto joined = client::joinServer([&]() -> client::ScanPublisher& { return pub; }, [] {},
                                         std::chrono::seconds(20), std::chrono::seconds(20), &context);
  if (!joined.joined)
    throw std::runtime_error(client::noServerMessage(context, std::chrono::seconds(20), joined.state));
  MappedWatch watch(service, scans.size(), 60);
  const auto t0 = Clock::now();
  for (std::size_t i = 0; i < scans.size(); ++i) {
    if (!fast)
      std::this_thread::sleep_until(
          t0 + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(i / rate)));
    pub.publish("robot-0", i, scans[i]);
    ++r.sent;
  }
  r.seconds = std::chrono::duration<double>(watch.done() - t0).count();
  const auto st = service.statistics();
  r.mapped = st.totals().processed;
  r.publish_to_map = st.publish_to_map;
  edge.stop();
  return r;
}

Run runRos2(const ros2::BagReader& bag, const std::string& cloud_topic, std::size_t clouds, int domain,
            bool fast) {
  Run r;
  r.kind = "ros2";
  r.fast = fast;
  server::MapService service(serviceOptions());
  server::ros2_edge::Ros2EdgeOptions ro;
  ro.enabled = ro.only = true;
  ro.frames.cloud_topic = cloud_topic;
  msg::DdsOptions d;
  d.domain = domain;
  d.loopback = true;
  server::ros2_edge::Ros2Edge edge(service, ro, d);
  d.name = "bench-bag-player";
  msg::DdsNode node(d);
  client::Ros2PlayOptions po;
  po.as_fast_as_possible = fast;
  po.wait_s = 20;
  po.where = client::joinContext(d, node, "").where;
  // Clouds are best effort (as recorded): when some are lost the watch ends at its timeout, and the
  // ingest rate counts only the mapped ones.
  MappedWatch watch(service, clouds, fast ? 5 : 60);
  const client::Ros2PlayResult played = client::playBag(bag, node, po);
  if (!played.unread_topic.empty())
    throw std::runtime_error("the ROS 2 edge did not read " + played.unread_topic);
  r.sent = played.clouds;
  // From the first message (matching left out, as for the native robot) to the last cloud in the map.
  r.seconds = std::chrono::duration<double>(watch.done() - played.first_sent).count();
  const auto st = service.statistics();
  r.mapped = st.totals().processed;
  r.publish_to_map = st.publish_to_map;
  r.tf_wait = edge.counters().tf_wait_ms;
  edge.stop();
  service.stop();
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "densemap-ros2-bench: ROS 2 clouds + TF against densemap scans of the same recording, in one run"};
  std::string source = DENSEMAP_DEFAULT_BAG, log_level = "warn";
  int rounds = 3, domain = 171;
  app.add_option("--source", source, "a ROS 2 bag with one PointCloud2 topic and TF")->capture_default_str();
  app.add_option("--rounds", rounds, "rounds; each runs both kinds, in alternating order")
      ->capture_default_str()
      ->check(CLI::Range(1, 100));
  app.add_option("--domain", domain, "DDS domain (loopback only)")
      ->capture_default_str()
      ->check(CLI::Range(0, 232));
  app.add_option("--log-level", log_level, "log level")->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  cli::setupLogging(log_level);
  try {
    ros2::BagScanSource src(source, {});
    std::vector<io::Scan> scans;
    for (std::size_t i = 0; i < src.size(); ++i) scans.push_back(src.read(i));
    std::string cloud_topic;
    for (const auto& t : src.bag().topics())
      if (t.type == ros2::kPointCloud2Type) cloud_topic = t.name;
    // The recorded rate, for the native robot's timing.
    std::vector<std::int64_t> stamps;
    for (const auto& m : src.bag().messages())
      if (src.bag().topics()[m.topic].name == cloud_topic) stamps.push_back(m.log_time_ns);
    const double rate =
        stamps.size() > 1 ? 1e9 * double(stamps.size() - 1) / double(stamps.back() - stamps.front()) : 10.0;
    std::printf("source %s: %zu clouds at %.1f Hz; %d rounds, orders alternate\n", source.c_str(),
                scans.size(), rate, rounds);
    std::printf("%-9s %-5s %6s %6s %9s %9s %9s %9s %9s\n", "kind", "mode", "sent", "mapped", "clouds/s",
                "p50 ms", "p99 ms", "tf p50", "tf p99");
    std::vector<Run> runs;
    for (int r = 0; r < rounds; ++r)
      for (bool fast : {false, true})
        for (int k = 0; k < 2; ++k) {
          const bool ros2_first = r % 2 == 1;
          const bool ros2 = (k == 0) == ros2_first;
          Run run = ros2 ? runRos2(src.bag(), cloud_topic, scans.size(), domain, fast)
                         : runNative(scans, domain, fast, rate);
          std::printf("%-9s %-5s %6zu %6zu %9.1f %9.1f %9.1f %9.2f %9.2f\n", run.kind.c_str(),
                      fast ? "fast" : "timed", run.sent, run.mapped, run.mapped / run.seconds,
                      run.publish_to_map.p50_ms, run.publish_to_map.p99_ms, run.tf_wait.p50_ms,
                      run.tf_wait.p99_ms);
          std::fflush(stdout);
          runs.push_back(run);
        }
    auto median = [&](const std::string& kind, bool fast, auto field) {
      std::vector<double> v;
      for (const Run& r : runs)
        if (r.kind == kind && r.fast == fast) v.push_back(field(r));
      return util::percentile(v, 0.5);
    };
    std::printf("\nmedians over %d rounds (ros2 / densemap)\n", rounds);
    const auto p50 = [](const Run& r) { return r.publish_to_map.p50_ms; };
    const auto p99 = [](const Run& r) { return r.publish_to_map.p99_ms; };
    const auto ingest = [](const Run& r) { return r.mapped / r.seconds; };
    const auto tf50 = [](const Run& r) { return r.tf_wait.p50_ms; };
    const auto tf99 = [](const Run& r) { return r.tf_wait.p99_ms; };
    std::printf("publish-to-map p50 at the recorded rate: ros2 %.1f ms, densemap %.1f ms, ratio %.2f\n",
                median("ros2", false, p50), median("densemap", false, p50),
                median("ros2", false, p50) / median("densemap", false, p50));
    std::printf("publish-to-map p99 at the recorded rate: ros2 %.1f ms, densemap %.1f ms, ratio %.2f\n",
                median("ros2", false, p99), median("densemap", false, p99),
                median("ros2", false, p99) / median("densemap", false, p99));
    std::printf("ingest as fast as possible: ros2 %.1f clouds/s, densemap %.1f scans/s, ratio %.2f\n",
                median("ros2", true, ingest), median("densemap", true, ingest),
                median("ros2", true, ingest) / median("densemap", true, ingest));
    std::printf("time clouds waited for TF at the recorded rate: p50 %.2f ms, p99 %.2f ms\n",
                median("ros2", false, tf50), median("ros2", false, tf99));
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
  return 0;
}
