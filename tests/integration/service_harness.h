// An in-process densemap-server on DDS loopback with a robot (ScanPublisher) and a query client, for the
// service tests. Every test passes its own DDS domain id so tests can run in parallel.
#pragma once

#include <chrono>
#include <cmath>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "densemap/client/query_client.h"
#include "densemap/client/scan_publisher.h"
#include "densemap/io/lidar_simulator.h"
#include "densemap/map/grid_map.h"
#include "densemap/map/octree_map.h"
#include "densemap/server/dds_edge/dds_edge.h"
#include "densemap/server/dds_edge/wire.h"
#include "densemap/server/map_service.h"
#include "densemap/update/update_engine.h"
#include "test_simulator.h"

namespace densemap::test {

using namespace std::chrono_literals;

/// The service's options and its DDS edge's, in one struct as densemap-server takes them.
struct ServerOptions : server::ServiceOptions {
  msg::DdsOptions dds{};
  int query_threads = 2;
  std::size_t query_backlog = 64;
  double duplicate_check_s = 0.0;  // tests start many servers, each on its own domain
  int latency_slice_us = 100;
  int realtime_priority = 0;
  double statistics_period_s = 1.0;

  server::dds_edge::DdsEdgeOptions edge() const {
    server::dds_edge::DdsEdgeOptions e;
    e.dds = dds;
    e.query_threads = query_threads;
    e.query_backlog = query_backlog;
    e.duplicate_check_s = duplicate_check_s;
    e.latency_slice_us = latency_slice_us;
    e.realtime_priority = realtime_priority;
    e.statistics_period_s = statistics_period_s;
    return e;
  }
};

/// A map directory of the test's own (removed first, so nothing from an earlier run is loaded).
inline std::string testMapDir(int domain) {
  const auto dir = std::filesystem::temp_directory_path() / ("densemap-test-maps-" + std::to_string(domain));
  std::filesystem::remove_all(dir);
  return dir.string();
}

inline ServerOptions serverOptions(int domain) {
  ServerOptions o;
  o.dds.domain = domain;
  o.dds.loopback = true;
  o.statistics_period_s = 0.2;
  o.map_dir = testMapDir(domain);
  o.data_dir = o.map_dir + "-data";  // the journal and snapshots of this test alone
  std::filesystem::remove_all(o.data_dir);
  return o;
}

/// densemap-server in this process: the service under its DDS edge.
struct TestServer {
  explicit TestServer(const ServerOptions& o) : service(o), edge(service, o.edge()) {}
  msg::ServerStatistics statistics() { return server::dds_edge::toWire(service.statistics()); }
  const server::DenseStore* denseStore() { return service.denseStore(); }

  server::MapService service;
  server::dds_edge::DdsEdge edge;
};

struct ServiceHarness {
  explicit ServiceHarness(const ServerOptions& options) {
    server = std::make_unique<TestServer>(options);
    msg::DdsOptions dds = options.dds;
    dds.name = "test-client";
    node = std::make_unique<msg::DdsNode>(dds);
    robot = std::make_unique<client::ScanPublisher>(*node, std::vector<std::string>{"robot-0"});
    query = std::make_unique<client::QueryClient>(*node, "test-client");
    admin = std::make_unique<client::AdminClient>(*node, "test-admin");
    EXPECT_TRUE(robot->waitForServer(20s)) << "the robot did not discover the server";
    EXPECT_TRUE(query->waitForServer(20s)) << "the query client did not discover the server";
    EXPECT_TRUE(admin->waitForServer(20s)) << "the admin client did not discover the server";
  }
  ~ServiceHarness() {
    admin.reset();
    query.reset();
    robot.reset();
    node.reset();
    server.reset();
  }

  /// Publishes the scans as one robot and waits for every acknowledgement.
  client::AckCounts replay(const std::vector<io::Scan>& scans, const std::string& id = "robot-0",
                           std::uint64_t first_seq = 0) {
    for (std::size_t i = 0; i < scans.size(); ++i) EXPECT_TRUE(robot->publish(id, first_seq + i, scans[i]));
    return robot->waitForAcks({id}, first_seq + scans.size(), 120s);
  }

  msg::QueryReply stats() {
    msg::QueryRequest rq;
    rq.kind(msg::QUERY_STATS);
    return query->call(rq, 30s);
  }

  std::unique_ptr<TestServer> server;
  std::unique_ptr<msg::DdsNode> node;
  std::unique_ptr<client::ScanPublisher> robot;
  std::unique_ptr<client::QueryClient> query;
  std::unique_ptr<client::AdminClient> admin;
};

/// The scan as the server rebuilds it from the message: the pose goes through position + quaternion.
inline io::Scan asSent(io::Scan scan) {
  const Eigen::Vector3d t = scan.pose.translation();
  scan.pose = io::poseFromQuaternion({t.x(), t.y(), t.z()}, io::quaternionOf(scan.pose));
  return scan;
}

/// The core's offline map of the same scans (as sent), with the server's default update options.
template <class Map>
std::unique_ptr<Map> offlineMap(const std::vector<io::Scan>& scans, double resolution,
                                const update::UpdateOptions& options = {}) {
  auto m = std::make_unique<Map>(resolution);
  update::UpdateEngine engine(options);
  for (const io::Scan& s : scans) {
    const io::Scan sent = asSent(s);
    engine.insert(*m, sent.worldPoints(), sent.origin());
  }
  return m;
}

inline std::vector<io::Scan> readScans(const io::ScanSource& src, std::size_t first, std::size_t last) {
  std::vector<io::Scan> out;
  for (std::size_t i = first; i <= last && i < src.size(); ++i) out.push_back(src.read(i));
  return out;
}

inline float probability(float log_odds) { return map::OccupancyParams::probability(log_odds); }

/// Every known cell of `offline` is served with the same probability and state, and the server knows no
/// other cell.
inline void expectServedEquals(ServiceHarness& h, const map::OccupancyMap& offline) {
  const auto stats = h.stats();
  ASSERT_EQ(stats.status(), msg::STATUS_OK) << stats.message();
  EXPECT_EQ(stats.stats().known_cells(), offline.knownCells());
  std::vector<geometry::VoxelKey> keys;
  std::vector<float> expected;
  offline.forEachCell([&](const geometry::VoxelKey& k, float v) {
    keys.push_back(k);
    expected.push_back(v);
  });
  ASSERT_FALSE(keys.empty());
  const float threshold = map::OccupancyParams::logOdds(offline.params().occupied_threshold);
  std::size_t mismatches = 0;
  constexpr std::size_t kChunk = 200'000;
  for (std::size_t begin = 0; begin < keys.size(); begin += kChunk) {
    const std::size_t end = std::min(keys.size(), begin + kChunk);
    msg::QueryRequest rq;
    rq.kind(msg::QUERY_POINTS);
    for (std::size_t i = begin; i < end; ++i) {
      const auto c = offline.converter().toCoord(keys[i]);
      rq.points().insert(rq.points().end(), {c.x(), c.y(), c.z()});
    }
    const auto r = h.query->call(rq, 60s);
    ASSERT_EQ(r.status(), msg::STATUS_OK) << r.message();
    ASSERT_EQ(r.probabilities().size(), end - begin);
    for (std::size_t i = begin; i < end; ++i) {
      const std::uint8_t want = expected[i] >= threshold ? msg::CELL_OCCUPIED : msg::CELL_FREE;
      if (r.states()[i - begin] != want || r.probabilities()[i - begin] != probability(expected[i])) {
        if (++mismatches <= 5) {
          ADD_FAILURE() << "cell " << keys[i][0] << "," << keys[i][1] << "," << keys[i][2]
                        << ": served p=" << r.probabilities()[i - begin] << " state "
                        << int(r.states()[i - begin]) << ", offline p=" << probability(expected[i]);
        }
      }
    }
  }
  EXPECT_EQ(mismatches, 0u) << "of " << keys.size() << " cells";
}

inline std::vector<io::Scan> simScans(int n) {
  io::LidarSimulator sim(smallSimulator(n));
  return readScans(sim, 0, static_cast<std::size_t>(n - 1));
}

}  // namespace densemap::test
