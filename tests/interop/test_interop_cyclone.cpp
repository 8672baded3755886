// densemap with a DDS nobody here wrote: robots, clients and ROS 2 nodes on Eclipse Cyclone DDS 0.10 (Debian
// 12's, the DDS under rmw_cyclonedds_cpp), written against Cyclone's C API with types Cyclone's idlc
// generated from densemap.idl, idl/ros2/ros2_messages.idl and interop_types.idl. Each asserts the map or
// the answer against densemap's own client on the same data. The server runs in this process on Fast DDS;
// Cyclone reaches it over UDP on 127.0.0.1.
#include <signal.h>
#include <sys/wait.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include <gtest/gtest.h>

#include "cyclone_node.h"
#include "densemap.h"  // Cyclone's C types of densemap.idl (idlc), not Fast DDS's (densemap/msg/...)
#include "densemap/client/ros2_player.h"
#include "densemap/map/map_file.h"
#include "densemap/map/map_projection.h"
#include "densemap/msg/peer_topic.h"
#include "densemap/ros2/message_codec.h"
#include "densemap/ros2/scan_messages.h"
#include "interop_types.h"
#include "ros2_messages.h"
#include "ros2_test_node.h"
#include "service_harness.h"
#include "spawn_process.h"

namespace densemap::test {
namespace {

using namespace std::chrono_literals;
using cyclone::Qos;

std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

/// A densemap robot on Cyclone: its own scan, acknowledgement and progress topics, named as densemap names
/// them (msg/peer_topic.h: the id's '-' and '.' escaped, so Cyclone 0.10 accepts the names).
struct CycloneRobot {
  CycloneRobot(cyclone::Node& node, std::string robot_id) : id(std::move(robot_id)) {
    scans = node.writer(node.topic(&densemap_msg_Scan_v1_desc, msg::peerTopicOf(msg::kScanTopic, id)),
                        Qos{true, false, true, 0});
    acks = node.reader(node.topic(&densemap_msg_ScanAck_v1_desc, msg::peerTopicOf(msg::kScanAckTopic, id)),
                       Qos{true, false, true, 0});
    progress = node.reader(
        node.topic(&densemap_msg_RobotProgress_v1_desc, msg::peerTopicOf(msg::kRobotProgressTopic, id)),
        Qos{true, true, false, 1});
  }
  /// The server reads our scans and writes our acknowledgements.
  bool joined() { return cyclone::waitMatched(scans) && cyclone::waitMatched(acks); }
  bool publish(std::uint64_t seq, const io::Scan& scan) {
    msg::Scan m = client::toMessage(id, seq, scan);  // the same floats densemap's robot sends
    densemap_msg_Scan_v1 s{};
    s.robot_id = id.data();
    s.seq = m.seq();
    s.stamp_ns = m.stamp_ns();
    s.publish_ns = msg::nowNs();
    s.frame_id = m.frame_id().data();
    s.sensor_pose = {m.sensor_pose().px(), m.sensor_pose().py(), m.sensor_pose().pz(), m.sensor_pose().qw(),
                     m.sensor_pose().qx(), m.sensor_pose().qy(), m.sensor_pose().qz()};
    s.points = cyclone::viewOf<dds_sequence_float>(m.points().data(), m.points().size());
    s.lidar = {m.lidar().rows(), m.lidar().columns(), m.lidar().fov_up_deg(), m.lidar().fov_down_deg(),
               m.lidar().fov_horizontal_deg()};
    return dds_write(scans, &s) == DDS_RETCODE_OK;
  }
  struct Ack {
    std::uint64_t seq;
    densemap_msg_ScanOutcome outcome;
    bool durable;
    std::string server_id;
  };
  std::optional<Ack> nextAck(std::chrono::milliseconds timeout = 60s) {
    std::optional<Ack> a;
    cyclone::takeOne<densemap_msg_ScanAck_v1>(acks, timeout, [&](const densemap_msg_ScanAck_v1& m) {
      a = Ack{m.seq, m.outcome, m.durable, m.server_id};
    });
    return a;
  }

  std::string id;
  dds_entity_t scans, acks, progress;
};

/// A densemap query and admin client on Cyclone, replies on its own topics.
struct CycloneClient {
  CycloneClient(cyclone::Node& node, std::string client_id) : id(std::move(client_id)) {
    queries = node.writer(node.topic(&densemap_msg_QueryRequest_v1_desc, msg::kQueryRequestTopic),
                          Qos{true, false, true, 0});
    replies =
        node.reader(node.topic(&densemap_msg_QueryReply_v1_desc, msg::peerTopicOf(msg::kQueryReplyTopic, id)),
                    Qos{true, false, true, 0});
    commands = node.writer(node.topic(&densemap_msg_AdminRequest_v1_desc, msg::kAdminRequestTopic),
                           Qos{true, false, true, 0});
    command_replies =
        node.reader(node.topic(&densemap_msg_AdminReply_v1_desc, msg::peerTopicOf(msg::kAdminReplyTopic, id)),
                    Qos{true, false, true, 0});
  }
  bool joined() {
    return cyclone::waitMatched(queries) && cyclone::waitMatched(replies) && cyclone::waitMatched(commands) &&
           cyclone::waitMatched(command_replies);
  }
  /// Sends `rq` (its id and request number filled in) and hands the reply to `check`.
  bool query(densemap_msg_QueryRequest_v1 rq,
             const std::function<void(const densemap_msg_QueryReply_v1&)>& check) {
    rq.client_id = id.data();
    rq.request_id = ++requests;
    if (dds_write(queries, &rq) != DDS_RETCODE_OK) return false;
    bool answered = false;
    while (!answered) {
      bool got = cyclone::takeOne<densemap_msg_QueryReply_v1>(replies, 30s,
                                                              [&](const densemap_msg_QueryReply_v1& r) {
                                                                if (r.request_id != rq.request_id) return;
                                                                answered = true;
                                                                check(r);
                                                              });
      if (!got) return false;
    }
    return true;
  }
  std::optional<std::pair<densemap_msg_QueryStatus, std::uint64_t>> command(densemap_msg_AdminRequest_v1 rq) {
    rq.client_id = id.data();
    rq.request_id = ++requests;
    if (dds_write(commands, &rq) != DDS_RETCODE_OK) return std::nullopt;
    std::optional<std::pair<densemap_msg_QueryStatus, std::uint64_t>> out;
    while (!out) {
      if (!cyclone::takeOne<densemap_msg_AdminReply_v1>(command_replies, 30s,
                                                        [&](const densemap_msg_AdminReply_v1& r) {
                                                          if (r.request_id == rq.request_id)
                                                            out = std::make_pair(r.status, r.cells_changed);
                                                        }))
        return std::nullopt;
    }
    return out;
  }

  std::string id;
  std::uint64_t requests = 0;
  dds_entity_t queries, replies, commands, command_replies;
};

densemap_msg_AdminRequest_v1 adminRequest(densemap_msg_AdminKind kind, const char* name = "") {
  densemap_msg_AdminRequest_v1 rq{};
  rq.kind = kind;
  rq.name = const_cast<char*>(name);
  return rq;
}

TEST(CycloneDds, ARobotOnCycloneIsMappedAckedAndResendsAsDensemapsOwnRobot) {
  constexpr int kCyclone = 40, kDensemap = 41;
  const std::vector<io::Scan> scans = simScans(6);
  const std::string robot = "cyclone-robot.1";  // '-' and '.': names Cyclone 0.10 refuses unescaped
  TestServer server(serverOptions(kCyclone));
  cyclone::Node node(kCyclone);
  CycloneRobot r(node, robot);
  ASSERT_TRUE(r.joined()) << "the server did not match the Cyclone robot's scan writer and ack reader";
  for (std::size_t i = 0; i < scans.size(); ++i) ASSERT_TRUE(r.publish(i, scans[i]));
  std::set<std::uint64_t> applied;
  for (std::size_t i = 0; i < scans.size(); ++i) {
    const auto ack = r.nextAck();
    ASSERT_TRUE(ack) << "acknowledgement " << i << " did not come";
    EXPECT_EQ(ack->outcome, densemap_msg_SCAN_APPLIED);
    EXPECT_TRUE(ack->durable);
    EXPECT_FALSE(ack->server_id.empty());
    applied.insert(ack->seq);
  }
  EXPECT_EQ(applied.size(), scans.size());
  // A resend is acknowledged as a duplicate and not applied again.
  ASSERT_TRUE(r.publish(2, scans[2]));
  const auto dup = r.nextAck();
  ASSERT_TRUE(dup);
  EXPECT_EQ(dup->seq, 2u);
  EXPECT_EQ(dup->outcome, densemap_msg_SCAN_DUPLICATE);
  // The robot's progress says what the server holds, so the robot knows what to resend.
  std::uint64_t last_durable = 0, durable_scans = 0;
  const auto until = std::chrono::steady_clock::now() + 10s;
  while (durable_scans < scans.size() && std::chrono::steady_clock::now() < until) {
    cyclone::takeOne<densemap_msg_RobotProgress_v1>(
        r.progress, 1s, [&](const densemap_msg_RobotProgress_v1& p) {
          for (std::uint32_t i = 0; i < p.robots._length; ++i) {
            if (robot != p.robots._buffer[i].robot_id) continue;
            last_durable = p.robots._buffer[i].last_durable_sequence;
            durable_scans = p.robots._buffer[i].durable_scans;
          }
        });
  }
  EXPECT_EQ(durable_scans, scans.size());
  EXPECT_EQ(last_durable, scans.size() - 1);

  // The same scans from densemap's own robot, and both maps saved by the clients: the same .ot bytes.
  ServiceHarness own(serverOptions(kDensemap));
  const client::AckCounts c = own.replay(scans, robot);
  ASSERT_EQ(c.applied, scans.size());
  CycloneClient admin(node, "cyclone-admin");
  ASSERT_TRUE(admin.joined());
  const auto saved = admin.command(adminRequest(densemap_msg_ADMIN_SAVE, "served.ot"));
  ASSERT_TRUE(saved);
  EXPECT_EQ(saved->first, densemap_msg_STATUS_OK);
  msg::AdminRequest own_save;
  own_save.kind(msg::ADMIN_SAVE);
  own_save.name("served.ot");
  ASSERT_EQ(own.admin->call(own_save, 30s).status(), msg::STATUS_OK);
  const std::string a = slurp(std::filesystem::path(server.service.options().map_dir) / "served.ot");
  const std::string b = slurp(std::filesystem::path(own.server->service.options().map_dir) / "served.ot");
  ASSERT_GT(a.size(), 1000u);
  EXPECT_TRUE(a == b) << "the Cyclone robot's map (" << a.size() << " bytes) differs from densemap's ("
                      << b.size() << " bytes)";
}

TEST(CycloneDds, QueryAndAdminClientsOnCycloneAreAnsweredAsDensemapsOwn) {
  constexpr int kDomain = 43;
  const std::vector<io::Scan> scans = simScans(5);
  ServiceHarness own(serverOptions(kDomain));
  ASSERT_EQ(own.replay(scans).applied, scans.size());
  cyclone::Node node(kDomain);
  CycloneClient cyc(node, "cyclone-query.7");
  ASSERT_TRUE(cyc.joined()) << "the server did not match the Cyclone client's request and reply topics";

  // Points: every cell the offline map knows and a few it does not.
  const auto offline = offlineMap<map::GridMap>(scans, own.server->service.options().map.resolution);
  std::vector<float> points;
  offline->forEachCell([&](const geometry::VoxelKey& k, float) {
    if (points.size() >= 3 * 2000) return;
    const auto c = offline->converter().toCoord(k);
    points.insert(points.end(), {float(c.x()), float(c.y()), float(c.z())});
  });
  points.insert(points.end(), {500.f, 500.f, 500.f, -3.f, 7.f, 40.f});
  msg::QueryRequest own_points;
  own_points.kind(msg::QUERY_POINTS);
  own_points.points(points);
  const msg::QueryReply want_points = own.query->call(own_points, 30s);
  ASSERT_EQ(want_points.status(), msg::STATUS_OK);
  densemap_msg_QueryRequest_v1 rq{};
  rq.kind = densemap_msg_QUERY_POINTS;
  rq.points = cyclone::viewOf<dds_sequence_float>(points.data(), points.size());
  ASSERT_TRUE(cyc.query(rq, [&](const densemap_msg_QueryReply_v1& r) {
    EXPECT_EQ(r.status, densemap_msg_STATUS_OK);
    ASSERT_EQ(r.probabilities._length, want_points.probabilities().size());
    ASSERT_EQ(r.states._length, want_points.states().size());
    EXPECT_EQ(0, std::memcmp(r.probabilities._buffer, want_points.probabilities().data(),
                             want_points.probabilities().size() * sizeof(float)));
    EXPECT_EQ(0, std::memcmp(r.states._buffer, want_points.states().data(), want_points.states().size()));
    EXPECT_EQ(r.map_version, want_points.map_version());
  }));

  // A box, a ray and the statistics.
  msg::QueryRequest own_box;
  own_box.kind(msg::QUERY_BOX);
  own_box.box_min({-20.f, -20.f, -3.f});
  own_box.box_max({20.f, 20.f, 5.f});
  const msg::QueryReply want_box = own.query->call(own_box, 30s);
  ASSERT_EQ(want_box.status(), msg::STATUS_OK);
  ASSERT_FALSE(want_box.cells().empty());
  rq = {};
  rq.kind = densemap_msg_QUERY_BOX;
  std::memcpy(rq.box_min, own_box.box_min().data(), sizeof rq.box_min);
  std::memcpy(rq.box_max, own_box.box_max().data(), sizeof rq.box_max);
  ASSERT_TRUE(cyc.query(rq, [&](const densemap_msg_QueryReply_v1& r) {
    EXPECT_EQ(r.status, densemap_msg_STATUS_OK);
    ASSERT_EQ(r.cells._length, want_box.cells().size());
    EXPECT_EQ(0,
              std::memcmp(r.cells._buffer, want_box.cells().data(), want_box.cells().size() * sizeof(float)));
    EXPECT_EQ(r.truncated, want_box.truncated());
  }));
  msg::QueryRequest own_ray;
  own_ray.kind(msg::QUERY_RAY);
  own_ray.ray_origin({0.f, 0.f, 1.f});
  own_ray.ray_direction({1.f, 0.2f, 0.f});
  own_ray.max_range(60.f);
  const msg::QueryReply want_ray = own.query->call(own_ray, 30s);
  ASSERT_EQ(want_ray.status(), msg::STATUS_OK);
  rq = {};
  rq.kind = densemap_msg_QUERY_RAY;
  std::memcpy(rq.ray_origin, own_ray.ray_origin().data(), sizeof rq.ray_origin);
  std::memcpy(rq.ray_direction, own_ray.ray_direction().data(), sizeof rq.ray_direction);
  rq.max_range = own_ray.max_range();
  ASSERT_TRUE(cyc.query(rq, [&](const densemap_msg_QueryReply_v1& r) {
    EXPECT_EQ(r.hit, want_ray.hit());
    EXPECT_EQ(0, std::memcmp(r.hit_point, want_ray.hit_point().data(), sizeof r.hit_point));
  }));
  const msg::QueryReply want_stats = own.stats();
  rq = {};
  rq.kind = densemap_msg_QUERY_STATS;
  ASSERT_TRUE(cyc.query(rq, [&](const densemap_msg_QueryReply_v1& r) {
    EXPECT_EQ(r.stats.known_cells, want_stats.stats().known_cells());
    EXPECT_EQ(r.stats.occupied_cells, want_stats.stats().occupied_cells());
    EXPECT_EQ(r.stats.map_version, want_stats.stats().map_version());
    EXPECT_STREQ(r.server_id, want_stats.server_id().c_str());
  }));

  // Commands: a cleared box forgets what densemap's own client's box query found there; a reset forgets all.
  densemap_msg_AdminRequest_v1 clear = adminRequest(densemap_msg_ADMIN_CLEAR_BOX);
  std::memcpy(clear.box_min, own_box.box_min().data(), sizeof clear.box_min);
  std::memcpy(clear.box_max, own_box.box_max().data(), sizeof clear.box_max);
  const auto cleared = cyc.command(clear);
  ASSERT_TRUE(cleared);
  EXPECT_EQ(cleared->first, densemap_msg_STATUS_OK);
  EXPECT_GE(cleared->second, want_box.cells().size() / 3);
  EXPECT_TRUE(own.query->call(own_box, 30s).cells().empty());
  const auto reset = cyc.command(adminRequest(densemap_msg_ADMIN_RESET));
  ASSERT_TRUE(reset);
  EXPECT_EQ(reset->first, densemap_msg_STATUS_OK);
  EXPECT_EQ(own.stats().stats().known_cells(), 0u);
  // A load naming a path, not a file name, is refused with the reason and changes nothing.
  ASSERT_EQ(own.replay(scans, "robot-0", scans.size()).applied, 2 * scans.size());  // counts from the start
  const std::uint64_t known = own.stats().stats().known_cells();
  const auto hostile = cyc.command(adminRequest(densemap_msg_ADMIN_LOAD, "../../etc/passwd.ot"));
  ASSERT_TRUE(hostile);
  EXPECT_EQ(hostile->first, densemap_msg_STATUS_INVALID_ARGUMENT);
  EXPECT_EQ(own.stats().stats().known_cells(), known);
}

// ---- ROS 2 over Cyclone: what a node on rmw_cyclonedds puts on the wire ----

server::ServiceOptions ros2ServiceOptions(int domain) {
  server::ServiceOptions o;
  o.map_dir = testMapDir(domain);
  o.data_dir = o.map_dir + "-data";
  std::filesystem::remove_all(o.data_dir);
  return o;
}

server::ros2_edge::Ros2EdgeOptions ros2EdgeOptions(const std::string& distribution = "humble") {
  server::ros2_edge::Ros2EdgeOptions o;
  o.enabled = o.only = true;
  o.map_publish_period_s = 0.2;
  o.ros_distribution = distribution;
  return o;
}

std::unique_ptr<map::OccupancyMap> served(Ros2Server& s) {
  return s.service.mapStore().read([](const map::OccupancyMap& m, std::uint64_t) { return m.clone(); });
}

/// A ROS 2 LiDAR node on Cyclone: PointCloud2 on /cloud_in (sensor-data QoS) and its pose on /tf, each scan
/// as densemap-replay --ros2 sends it (ros2::scanMessages), copied into Cyclone's generated types.
void publishAsCycloneRos2Node(cyclone::Node& node, Ros2Server& server, const std::vector<io::Scan>& scans) {
  const dds_entity_t clouds = node.writer(node.topic(&sensor_msgs_msg_dds__PointCloud2__desc, "rt/cloud_in"),
                                          Qos{false, false, false, 5});
  const dds_entity_t tf =
      node.writer(node.topic(&tf2_msgs_msg_dds__TFMessage__desc, "rt/tf"), Qos{true, false, false, 100});
  ASSERT_TRUE(cyclone::waitMatched(clouds) && cyclone::waitMatched(tf));
  ASSERT_TRUE(server.waitForPublishers()) << "the edge did not match the Cyclone node's publishers";
  const std::int64_t start = msg::nowNs();
  for (std::size_t i = 0; i < scans.size(); ++i) {
    const ros2::ScanMessages m =
        ros2::scanMessages(scans[i], start + std::int64_t(i) * 100'000'000, "map", "lidar");
    const ros2::TfMessage t = ros2::decodeTfMessage(m.transform);
    ASSERT_EQ(t.transforms.size(), 1u);
    const ros2::TransformStamped& ts = t.transforms[0];
    std::string parent = ts.header.frame_id, child = ts.child_frame_id;
    geometry_msgs_msg_dds__TransformStamped_ c{};
    c.header.stamp = {ts.header.stamp.sec, ts.header.stamp.nanosec};
    c.header.frame_id = parent.data();
    c.child_frame_id = child.data();
    c.transform.translation = {ts.translation[0], ts.translation[1], ts.translation[2]};
    c.transform.rotation = {ts.rotation.x, ts.rotation.y, ts.rotation.z, ts.rotation.w};
    tf2_msgs_msg_dds__TFMessage_ tm{};
    tm.transforms = cyclone::viewOf<dds_sequence_geometry_msgs_msg_dds__TransformStamped_>(&c, 1);
    ASSERT_EQ(dds_write(tf, &tm), DDS_RETCODE_OK);

    const ros2::PointCloud2 pc = ros2::decodePointCloud2(m.cloud);
    std::string frame = pc.header.frame_id;
    std::vector<std::string> names;
    std::vector<sensor_msgs_msg_dds__PointField_> fields;
    for (const auto& f : pc.fields) names.push_back(f.name);
    for (std::size_t k = 0; k < pc.fields.size(); ++k)
      fields.push_back({names[k].data(), pc.fields[k].offset, pc.fields[k].datatype, pc.fields[k].count});
    std::vector<std::uint8_t> data(pc.data.begin(), pc.data.end());
    sensor_msgs_msg_dds__PointCloud2_ cloud{};
    cloud.header.stamp = {pc.header.stamp.sec, pc.header.stamp.nanosec};
    cloud.header.frame_id = frame.data();
    cloud.height = pc.height;
    cloud.width = pc.width;
    cloud.fields =
        cyclone::viewOf<dds_sequence_sensor_msgs_msg_dds__PointField_>(fields.data(), fields.size());
    cloud.is_bigendian = pc.is_bigendian;
    cloud.point_step = pc.point_step;
    cloud.row_step = pc.row_step;
    cloud.data = cyclone::viewOf<dds_sequence_uint8>(data.data(), data.size());
    cloud.is_dense = pc.is_dense;
    ASSERT_EQ(dds_write(clouds, &cloud), DDS_RETCODE_OK);
    std::this_thread::sleep_for(100ms);  // 10 Hz, as a LiDAR publishes
  }
}

/// The same scans from densemap-replay --ros2's player on Fast DDS.
void publishAsDensemapRos2Node(int domain, Ros2Server& server, const std::vector<io::Scan>& scans) {
  Ros2TestNode player(domain, "densemap_replay");
  client::Ros2PlayOptions o;
  o.wait_s = 10;
  o.sensor_frame = "lidar";
  const client::Ros2PlayResult r = client::playScans(scans, player.node, o);
  EXPECT_EQ(r.clouds, scans.size());
  ASSERT_TRUE(server.waitForMapped(scans.size()));
}

/// True once a sample on the Cyclone `reader` holds `want` (its data field, as bytes) within `timeout`. The
/// map topics are reliable: the last publication may be a repair of lost fragments away (a heartbeat
/// period), so "the newest sample so far" is no test of what the subscriber ends up with.
/// Every data field a Cyclone subscriber holds: its history (deep enough for every publication of the test).
template <class T>
std::set<std::string> cycloneReceived(dds_entity_t reader) {
  std::set<std::string> got;
  while (cyclone::takeOne<T>(reader, got.empty() ? 5000ms : 1000ms, [&](const T& m) {
    got.insert(std::string(reinterpret_cast<const char*>(m.data._buffer), m.data._length));
  })) {
  }
  return got;
}

/// The same from densemap's own subscriber (Fast DDS) of the same server.
std::set<std::string> ownReceived(fdds::DataReader* r,
                                  const std::function<std::string(const std::vector<std::uint8_t>&)>& data) {
  std::set<std::string> got;
  while (auto b = Ros2TestNode::take(r, got.empty() ? 5000ms : 1000ms)) got.insert(data(*b));
  return got;
}

std::string bytesOf(const auto& v) {
  return std::string(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(v[0]));
}

TEST(CycloneDds, ARos2NodeOnCycloneIsMappedAndReadsEveryOutputAsDensemapsOwn) {
  constexpr int kCyclone = 44, kDensemap = 45;
  const std::vector<io::Scan> scans = simScans(3);
  Ros2Server a(ros2ServiceOptions(kCyclone), ros2EdgeOptions(), kCyclone);
  Ros2Server b(ros2ServiceOptions(kDensemap), ros2EdgeOptions(), kDensemap);
  cyclone::Node node(kCyclone);
  // A subscriber of every output, as rviz2 or Nav2 on rmw_cyclonedds would read them.
  const Qos maps{true, false, false, 100};  // every publication of the test stays in the history
  const dds_entity_t binary =
      node.reader(node.topic(&octomap_msgs_msg_dds__Octomap__desc, "rt/octomap_binary"), maps);
  const dds_entity_t full =
      node.reader(node.topic(&octomap_msgs_msg_dds__Octomap__desc, "rt/octomap_full"), maps);
  const dds_entity_t grid =
      node.reader(node.topic(&nav_msgs_msg_dds__OccupancyGrid__desc, "rt/projected_map"), maps);
  const dds_entity_t centres = node.reader(
      node.topic(&sensor_msgs_msg_dds__PointCloud2__desc, "rt/octomap_point_cloud_centers"), maps);
  for (dds_entity_t r : {binary, full, grid, centres}) ASSERT_TRUE(cyclone::waitMatched(r));
  // Matching is not symmetric: the edge sees these subscribers a moment after they see it, and a volatile
  // subscriber gets only what is published after that.
  auto edgeSees = [](Ros2Server& s) {
    const auto until = std::chrono::steady_clock::now() + 20s;
    while (s.edge.matchedMapSubscribers() == 0 && std::chrono::steady_clock::now() < until)
      std::this_thread::sleep_for(10ms);
    return s.edge.matchedMapSubscribers() > 0;
  };
  ASSERT_TRUE(edgeSees(a)) << "the edge did not match the Cyclone subscribers";
  Ros2TestNode tool(kDensemap, "rviz2");
  const ros2::Qos qos{true, false, false, 100};
  // densemap's own subscriber beside the Cyclone one on the Cyclone robot's server.
  Ros2TestNode beside(kCyclone, "rviz2_beside");
  auto* beside_binary = beside.subscriber("/octomap_binary", ros2::kOctomapType, qos);
  auto* beside_full = beside.subscriber("/octomap_full", ros2::kOctomapType, qos);
  auto* beside_grid = beside.subscriber("/projected_map", ros2::kOccupancyGridType, qos);
  auto* beside_centres = beside.subscriber("/octomap_point_cloud_centers", ros2::kPointCloud2Type, qos);
  auto* own_binary = tool.subscriber("/octomap_binary", ros2::kOctomapType, qos);
  auto* own_full = tool.subscriber("/octomap_full", ros2::kOctomapType, qos);
  auto* own_grid = tool.subscriber("/projected_map", ros2::kOccupancyGridType, qos);
  auto* own_centres = tool.subscriber("/octomap_point_cloud_centers", ros2::kPointCloud2Type, qos);
  ASSERT_TRUE(edgeSees(b)) << "the edge did not match densemap's own subscribers";

  publishAsCycloneRos2Node(node, a, scans);
  ASSERT_TRUE(a.waitForMapped(scans.size())) << a.service.statistics().summaryLine();
  EXPECT_EQ(a.edge.counters().clouds_received, scans.size());
  publishAsDensemapRos2Node(kDensemap, b, scans);
  // The same .ot bytes from both.
  const std::string want = map::octomapMessageData(*served(b), map::OctomapFormat::kFull);
  ASSERT_GT(want.size(), 1000u);
  EXPECT_TRUE(map::octomapMessageData(*served(a), map::OctomapFormat::kFull) == want);

  // What each output must hold once the last scan is in: densemap's own encodings of the map.
  const auto map = served(b);
  const std::string binary_data = map::octomapMessageData(*map, map::OctomapFormat::kBinary);
  const std::string full_data = map::octomapMessageData(*map, map::OctomapFormat::kFull);
  const map::ProjectedGrid projected = map::projectToGrid(*map, -1e6, 1e6);
  const std::string grid_data = bytesOf(projected.cells);
  std::string centres_data;
  for (const auto& c : map::occupiedCentres(*map))
    centres_data += bytesOf(std::array<float, 3>{c.x(), c.y(), c.z()});
  ASSERT_FALSE(grid_data.empty());
  ASSERT_FALSE(centres_data.empty());
  // densemap's own subscribers end with exactly these, on both servers. The Cyclone subscriber reads each
  // output, and every sample it got is byte for byte one that densemap's own subscriber beside it got.
  // It is not required to get the last one: Fast DDS 2.9 now and then never delivers a large reliable sample
  // to a Cyclone 0.10 reader, not even by repair (README "Other DDS implementations").
  auto octomap = [](const std::vector<std::uint8_t>& b) { return bytesOf(ros2::decodeOctomap(b).data); };
  auto grid_of = [](const std::vector<std::uint8_t>& b) {
    return bytesOf(ros2::decodeOccupancyGrid(b).data);
  };
  auto cloud_of = [](const std::vector<std::uint8_t>& b) { return bytesOf(ros2::decodePointCloud2(b).data); };
  const struct {
    const char* topic;
    std::set<std::string> cyclone, beside, own;
    const std::string& final_data;
  } outputs[] = {{"octomap_binary", cycloneReceived<octomap_msgs_msg_dds__Octomap_>(binary),
                  ownReceived(beside_binary, octomap), ownReceived(own_binary, octomap), binary_data},
                 {"octomap_full", cycloneReceived<octomap_msgs_msg_dds__Octomap_>(full),
                  ownReceived(beside_full, octomap), ownReceived(own_full, octomap), full_data},
                 {"projected_map", cycloneReceived<nav_msgs_msg_dds__OccupancyGrid_>(grid),
                  ownReceived(beside_grid, grid_of), ownReceived(own_grid, grid_of), grid_data},
                 {"octomap_point_cloud_centers", cycloneReceived<sensor_msgs_msg_dds__PointCloud2_>(centres),
                  ownReceived(beside_centres, cloud_of), ownReceived(own_centres, cloud_of), centres_data}};
  for (const auto& o : outputs) {
    EXPECT_TRUE(o.own.count(o.final_data)) << o.topic << ": densemap's own subscriber missed the final map";
    EXPECT_TRUE(o.beside.count(o.final_data))
        << o.topic << ": densemap's own subscriber missed the final map";
    EXPECT_FALSE(o.cyclone.empty()) << o.topic << ": the Cyclone subscriber got nothing";
    for (const std::string& d : o.cyclone)
      EXPECT_TRUE(o.beside.count(d)) << o.topic << ": the Cyclone subscriber got " << d.size()
                                     << " bytes that densemap's own subscriber never got";
  }
}

/// A service client as rmw_cyclonedds makes one: requests and replies framed with its 16-byte header.
struct CycloneServiceClient {
  /// `service`: the resolved ROS 2 name ("/octomap_server/clear_bbox").
  CycloneServiceClient(cyclone::Node& node, const std::string& service, const dds_topic_descriptor_t* request,
                       const char* request_type, const dds_topic_descriptor_t* response,
                       const char* response_type) {
    requests = node.writer(node.topic(request, "rq" + service + "Request", request_type),
                           Qos{true, false, false, 10});
    replies = node.reader(node.topic(response, "rr" + service + "Reply", response_type),
                          Qos{true, false, false, 10});
  }
  bool joined() { return cyclone::waitMatched(requests) && cyclone::waitMatched(replies); }
  /// The header of the next reply within `timeout`, with the sequence number `seq`.
  template <class Reply>
  bool replied(std::int64_t seq, std::chrono::milliseconds timeout,
               const std::function<void(const Reply&)>& check = {}) {
    bool ok = false;
    while (!ok && cyclone::takeOne<Reply>(replies, timeout, [&](const Reply& r) {
      if (r.client_id != kClientId || r.sequence_number != seq) return;
      ok = true;
      if (check) check(r);
    })) {
    }
    return ok;
  }
  static constexpr std::uint64_t kClientId = 0x0110'c1c1'0000'0042;
  dds_entity_t requests, replies;
};

TEST(CycloneDds, ServicesCalledAsRmwCycloneddsCallsThemAreReadInItsFramingAndRepliedInIt) {
  constexpr int kCyclone = 46, kDensemap = 47;
  const std::vector<io::Scan> scans = simScans(4);
  Ros2Server a(ros2ServiceOptions(kCyclone), ros2EdgeOptions(), kCyclone);
  Ros2Server b(ros2ServiceOptions(kDensemap), ros2EdgeOptions(), kDensemap);
  publishAsDensemapRos2Node(kCyclone, a, scans);
  publishAsDensemapRos2Node(kDensemap, b, scans);
  cyclone::Node node(kCyclone);
  CycloneServiceClient clear(
      node, "/octomap_server/clear_bbox", &rmw_cyclonedds_wire_BoundingBoxQuery_Request__desc,
      "octomap_msgs::srv::dds_::BoundingBoxQuery_Request_", &rmw_cyclonedds_wire_Empty__desc,
      "octomap_msgs::srv::dds_::BoundingBoxQuery_Response_");
  CycloneServiceClient reset(node, "/octomap_server/reset", &rmw_cyclonedds_wire_Empty__desc,
                             "std_srvs::srv::dds_::Empty_Request_", &rmw_cyclonedds_wire_Empty__desc,
                             "std_srvs::srv::dds_::Empty_Response_");
  ASSERT_TRUE(clear.joined() && reset.joined())
      << "the edge did not match rmw_cyclonedds-style service topics";

  // Refused, never executed: a request without the header its vendor frames requests with, and one with 8
  // bytes too many. No reply comes, the map is unchanged, both are counted.
  const std::uint64_t known =
      a.service.mapStore().read([](const map::OccupancyMap& m, std::uint64_t) { return m.knownCells(); });
  CycloneServiceClient bad_reset(node, "/octomap_server/reset", &rmw_cyclonedds_wire_Unframed_Empty__desc,
                                 "std_srvs::srv::dds_::Empty_Request_", &rmw_cyclonedds_wire_Empty__desc,
                                 "std_srvs::srv::dds_::Empty_Response_");
  CycloneServiceClient bad_clear(
      node, "/octomap_server/clear_bbox", &rmw_cyclonedds_wire_Oversized_BoundingBoxQuery_Request__desc,
      "octomap_msgs::srv::dds_::BoundingBoxQuery_Request_", &rmw_cyclonedds_wire_Empty__desc,
      "octomap_msgs::srv::dds_::BoundingBoxQuery_Response_");
  ASSERT_TRUE(bad_reset.joined() && bad_clear.joined());
  rmw_cyclonedds_wire_Unframed_Empty_ unframed{0};
  ASSERT_EQ(dds_write(bad_reset.requests, &unframed), DDS_RETCODE_OK);
  rmw_cyclonedds_wire_Oversized_BoundingBoxQuery_Request_ oversized{
      CycloneServiceClient::kClientId, 1, -50, -50, -5, 50, 50, 5, 0};
  ASSERT_EQ(dds_write(bad_clear.requests, &oversized), DDS_RETCODE_OK);
  const auto until = std::chrono::steady_clock::now() + 10s;
  while (a.edge.counters().service_refused < 2 && std::chrono::steady_clock::now() < until)
    std::this_thread::sleep_for(20ms);
  EXPECT_EQ(a.edge.counters().service_refused, 2u);
  EXPECT_FALSE(bad_clear.replied<rmw_cyclonedds_wire_Empty_>(1, 500ms));
  EXPECT_EQ(
      a.service.mapStore().read([](const map::OccupancyMap& m, std::uint64_t) { return m.knownCells(); }),
      known);

  // clear_bbox: the reply carries the request's header back; the map is the one densemap's own clearing
  // gives.
  rmw_cyclonedds_wire_BoundingBoxQuery_Request_ box{
      CycloneServiceClient::kClientId, 7, -10, -10, -2, 10, 10, 3};
  ASSERT_EQ(dds_write(clear.requests, &box), DDS_RETCODE_OK);
  EXPECT_TRUE(clear.replied<rmw_cyclonedds_wire_Empty_>(7, 10s)) << "no reply with the request's header";
  server::ClearBoxCommand own_clear;
  own_clear.min = {-10, -10, -2};
  own_clear.max = {10, 10, 3};
  ASSERT_EQ(b.service.execute(own_clear).status, server::Status::kOk);
  EXPECT_TRUE(map::octomapMessageData(*served(a), map::OctomapFormat::kFull) ==
              map::octomapMessageData(*served(b), map::OctomapFormat::kFull));
  EXPECT_LT(served(a)->knownCells(), known);

  // GetOctomap (octomap_binary) answers the map densemap's own tools read.
  CycloneServiceClient get(node, "/octomap_binary", &rmw_cyclonedds_wire_Empty__desc,
                           "octomap_msgs::srv::dds_::GetOctomap_Request_",
                           &rmw_cyclonedds_wire_GetOctomap_Response__desc,
                           "octomap_msgs::srv::dds_::GetOctomap_Response_");
  ASSERT_TRUE(get.joined());
  rmw_cyclonedds_wire_Empty_ get_rq{CycloneServiceClient::kClientId, 8, 0};
  ASSERT_EQ(dds_write(get.requests, &get_rq), DDS_RETCODE_OK);
  std::string got_map;
  EXPECT_TRUE(get.replied<rmw_cyclonedds_wire_GetOctomap_Response_>(
      8, 10s, [&](const rmw_cyclonedds_wire_GetOctomap_Response_& r) {
        EXPECT_TRUE(r.binary);
        got_map.assign(reinterpret_cast<const char*>(r.data._buffer), r.data._length);
      }));
  EXPECT_EQ(got_map, map::octomapMessageData(*served(b), map::OctomapFormat::kBinary));

  // reset: executed once, replied with the header.
  rmw_cyclonedds_wire_Empty_ reset_rq{CycloneServiceClient::kClientId, 9, 0};
  ASSERT_EQ(dds_write(reset.requests, &reset_rq), DDS_RETCODE_OK);
  EXPECT_TRUE(reset.replied<rmw_cyclonedds_wire_Empty_>(9, 10s));
  EXPECT_EQ(served(a)->knownCells(), 0u);
  const auto c = a.edge.counters();
  EXPECT_EQ(c.service_requests_header, 3u);
  EXPECT_EQ(c.service_refused, 2u);
}

/// Reads ros_discovery_info with the given generated layout and checks the edge's node in it.
template <class Info, class Gid>
void expectNodeAnnounced(cyclone::Node& node, const dds_topic_descriptor_t* desc, std::size_t gid_bytes) {
  const dds_entity_t r = node.reader(
      node.topic(desc, "ros_discovery_info", "rmw_dds_common::msg::dds_::ParticipantEntitiesInfo_"),
      Qos{true, true, false, 1});
  bool seen = false;
  const auto until = std::chrono::steady_clock::now() + 20s;
  while (!seen && std::chrono::steady_clock::now() < until) {
    cyclone::takeOne<Info>(r, 1s, [&](const Info& info) {
      for (std::uint32_t i = 0; i < info.node_entities_info_seq._length; ++i) {
        const auto& n = info.node_entities_info_seq._buffer[i];
        if (std::string(n.node_name) != "octomap_server") continue;
        seen = true;
        EXPECT_STREQ(n.node_namespace, "/");
        EXPECT_EQ(n.reader_gid_seq._length, 7u);  // cloud, /tf, /tf_static, four service requests
        EXPECT_EQ(n.writer_gid_seq._length, 8u);  // four maps, four service replies
        // A GID is the entity's 16-byte GUID: its participant's prefix, zero-padded to the Gid's size.
        const Gid& first = n.writer_gid_seq._buffer[0];
        EXPECT_EQ(0, std::memcmp(first.data, info.gid.data, 12));
        for (std::size_t k = 16; k < gid_bytes; ++k) EXPECT_EQ(first.data[k], 0);
      }
    });
  }
  EXPECT_TRUE(seen) << "no ParticipantEntitiesInfo naming /octomap_server on ros_discovery_info";
}

TEST(CycloneDds, TheRos2EdgeIsAnnouncedOnRosDiscoveryInfoInHumblesAndJazzysLayout) {
  {
    constexpr int kDomain = 48;
    Ros2Server a(ros2ServiceOptions(kDomain), ros2EdgeOptions("humble"), kDomain);
    cyclone::Node node(kDomain);
    expectNodeAnnounced<rmw_dds_common_msg_dds__ParticipantEntitiesInfo_, rmw_dds_common_msg_dds__Gid_>(
        node, &rmw_dds_common_msg_dds__ParticipantEntitiesInfo__desc, 24);
  }
  {
    constexpr int kDomain = 49;
    Ros2Server a(ros2ServiceOptions(kDomain), ros2EdgeOptions("jazzy"), kDomain);
    cyclone::Node node(kDomain);
    expectNodeAnnounced<jazzy_ParticipantEntitiesInfo_, jazzy_Gid_>(node,
                                                                    &jazzy_ParticipantEntitiesInfo__desc, 16);
  }
}

/// Round-trip times (ms) of `n` point queries by densemap's own client.
std::vector<double> queryTimesMs(ServiceHarness& h, int n) {
  msg::QueryRequest rq;
  rq.kind(msg::QUERY_POINTS);
  for (int i = 0; i < 100; ++i) rq.points().insert(rq.points().end(), {0.1f * float(i), 1.f, 0.5f});
  std::vector<double> ms;
  for (int i = 0; i < n; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    const msg::QueryReply r = h.query->call(rq, 10s);
    EXPECT_EQ(r.status(), msg::STATUS_OK);
    ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  }
  std::sort(ms.begin(), ms.end());
  return ms;
}

TEST(CycloneDds, DdsperfTrafficOnTheSameDomainLeavesEveryScanMappedAndEveryQueryAnswered) {
  // Cyclone's ddsperf publishing 4 kB samples at 200 Hz to a ddsperf subscriber on the server's domain,
  // started the way a user starts it (CYCLONEDDS_URI); the robot streams and the queries run meanwhile.
  // Query times are printed beside a run without it (a figure, not a pass/fail bound: no timed tests).
  constexpr int kDomain = 50;
  const std::vector<io::Scan> scans = simScans(20);
  ServiceHarness h(serverOptions(kDomain));
  const std::vector<double> quiet = queryTimesMs(h, 1000);
  setenv("CYCLONEDDS_URI", cyclone::loopbackConfig().c_str(), 1);
  const std::string domain = std::to_string(kDomain);
  const pid_t sub = spawnProcess({"/usr/bin/ddsperf", "-i", domain, "-D", "60", "sub"});
  const pid_t pub =
      spawnProcess({"/usr/bin/ddsperf", "-i", domain, "-D", "60", "pub", "200Hz", "size", "4k"});
  ASSERT_GT(sub, 0);
  ASSERT_GT(pub, 0);
  std::this_thread::sleep_for(3s);  // discovery, and the stream under way
  int status = 0;
  ASSERT_EQ(waitpid(pub, &status, WNOHANG), 0) << "ddsperf pub ended early";
  const client::AckCounts c = h.replay(scans);
  const std::vector<double> loaded = queryTimesMs(h, 1000);
  kill(pub, SIGTERM);
  kill(sub, SIGTERM);
  waitpid(pub, &status, 0);
  waitpid(sub, &status, 0);
  EXPECT_EQ(c.applied, scans.size());
  EXPECT_EQ(c.dropped + c.rejected, 0u);
  auto p99 = [](const std::vector<double>& v) { return v[v.size() * 99 / 100]; };
  std::printf("query p99 without ddsperf %.3f ms, with it %.3f ms (ratio %.2f; p50 %.3f / %.3f ms)\n",
              p99(quiet), p99(loaded), p99(loaded) / p99(quiet), quiet[quiet.size() / 2],
              loaded[loaded.size() / 2]);
}

}  // namespace
}  // namespace densemap::test
