// The ROS 2 edge end to end on DDS loopback: recorded ROS 2 bytes played as `ros2 bag play` would, the
// served map against the offline map of the same bag, octomap_msgs and projected_map as ROS 2 tools read
// them, services as rmw_fastrtps calls them, and every kind of bad input counted without a change.
#include <cmath>
#include <limits>
#include <sstream>

#include <fastdds/rtps/common/WriteParams.h>
#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include "densemap/client/ros2_player.h"
#include "densemap/io/lidar_simulator.h"
#include "densemap/map/grid_map.h"
#include "densemap/map/map_file.h"
#include "densemap/ros2/bag_reader.h"
#include "densemap/ros2/bag_scan_source.h"
#include "densemap/ros2/message_codec.h"
#include "densemap/ros2/scan_messages.h"
#include "densemap/ros2/sensor_pose.h"
#include "densemap/update/update_engine.h"
#include "ros2_test_node.h"
#include "security_keystore.h"
#include "service_harness.h"
#include "test_data.h"

namespace densemap::test {
namespace {

using server::ros2_edge::Ros2EdgeOptions;

server::ServiceOptions serviceOptions(int domain) {
  server::ServiceOptions o;
  o.map_dir = testMapDir(domain);
  o.data_dir = o.map_dir + "-data";
  std::filesystem::remove_all(o.data_dir);
  return o;
}

Ros2EdgeOptions ros2Options(const std::string& cloud_topic = "/cloud_in") {
  Ros2EdgeOptions o;
  o.enabled = o.only = true;
  o.frames.cloud_topic = cloud_topic;
  o.map_publish_period_s = 0.2;
  return o;
}

std::unique_ptr<map::OccupancyMap> served(Ros2Server& s) {
  return s.service.mapStore().read([](const map::OccupancyMap& m, std::uint64_t) { return m.clone(); });
}

std::unique_ptr<map::OccupancyMap> offlineOf(const std::vector<io::Scan>& scans, double resolution = 0.2) {
  auto m = std::make_unique<map::GridMap>(resolution);
  update::UpdateEngine engine(update::UpdateOptions{});
  for (const io::Scan& s : scans) engine.insert(*m, s.worldPoints(), s.origin());
  return m;
}

/// Cell for cell, log-odds bit for bit.
void expectSameMap(const map::OccupancyMap& got, const map::OccupancyMap& want) {
  ASSERT_GT(want.knownCells(), 0u);
  EXPECT_EQ(got.knownCells(), want.knownCells());
  std::size_t mismatches = 0;
  want.forEachCell([&](const geometry::VoxelKey& k, float v) {
    const auto g = got.logOdds(k);
    if (!g || *g != v) ++mismatches;
  });
  EXPECT_EQ(mismatches, 0u) << "of " << want.knownCells() << " cells";
}

void playBagInto(Ros2Server& server, const std::string& path, int domain, std::size_t clouds) {
  const auto bag = ros2::openBag(path);
  {
    Ros2TestNode player(domain, "ros2_bag_player");
    client::Ros2PlayOptions o;
    o.wait_s = 10;
    const client::Ros2PlayResult r = client::playBag(*bag, player.node, o);
    EXPECT_EQ(r.clouds, clouds);
  }
  ASSERT_TRUE(server.waitForMapped(clouds)) << server.service.statistics().summaryLine();
}

void expectBagServedAsOffline(const std::string& bag, int domain, const std::string& topic,
                              const std::string& frame, std::size_t clouds) {
  Ros2EdgeOptions o = ros2Options(topic);
  o.frames.fixed_frame = frame;
  Ros2Server server(serviceOptions(domain), o, domain);
  playBagInto(server, bag, domain, clouds);
  const auto c = server.edge.counters();
  EXPECT_EQ(c.clouds_received, clouds);
  EXPECT_EQ(c.clouds_submitted, clouds);
  EXPECT_EQ(c.clouds_waited_out, 0u);
  EXPECT_EQ(c.clouds_undecodable, 0u);
  ros2::BagSourceOptions so;
  so.frames.fixed_frame = frame;
  ros2::BagScanSource offline(bag, so);
  expectSameMap(*served(server), *offlineOf(readScans(offline, 0, offline.size() - 1)));
}

TEST(Ros2Edge, KittiMcapPlayedAsRos2IsServedExactlyAsTheOfflineMapOfTheBag) {
  DENSEMAP_REQUIRE_DATA("ros2/kitti00_0_19.mcap");
  expectBagServedAsOffline(dataDir() + "/ros2/kitti00_0_19.mcap", 180, "/points", "map", 20);
}

TEST(Ros2Edge, KittiSqliteBagPlayedAsRos2IsServedExactlyAsTheOfflineMapOfTheBag) {
  DENSEMAP_REQUIRE_DATA("ros2/kitti00_0_19");
  expectBagServedAsOffline(dataDir() + "/ros2/kitti00_0_19", 181, "/points", "map", 20);
}

TEST(Ros2Edge, Os1OrganisedPaddedCloudsThroughAStaticChain) {
  DENSEMAP_REQUIRE_DATA("ros2/os1_indoor");
  expectBagServedAsOffline(dataDir() + "/ros2/os1_indoor", 182, "/os1_cloud_node/points", "os1_sensor", 2);
}

/// The simulator's scans as the server places them: through a TF message and the buffer, as sent.
std::vector<io::Scan> asPlacedThroughTf(const std::vector<io::Scan>& scans) {
  std::vector<io::Scan> out;
  for (const io::Scan& s : scans) {
    const ros2::ScanMessages m = ros2::scanMessages(s, 1, "map", "lidar");
    ros2::TfBuffer tf;
    EXPECT_TRUE(ros2::addTfMessage(tf, m.transform, false).empty());
    const ros2::TfLookup l = tf.lookup("map", "lidar", 1);
    const ros2::SensorPose p = ros2::sensorPoseOf(l.transform);
    io::Scan placed = s;
    placed.points = s.sensorPoints();
    placed.frame = io::PointFrame::kSensor;
    placed.pose = io::poseFromQuaternion(p.position, p.wxyz);
    out.push_back(placed);
  }
  return out;
}

/// The simulator's scans published as a ROS 2 robot does (PointCloud2 + /tf at 10 Hz), from a participant
/// of its own that leaves once they are sent.
void publishAsRos2Robot(int domain, const std::vector<io::Scan>& scans) {
  Ros2TestNode robot(domain, "sim_robot");
  client::Ros2PlayOptions o;
  o.rate = 10;
  o.wait_s = 10;
  EXPECT_EQ(client::playScans(scans, robot.node, o).clouds, scans.size());
}

TEST(Ros2Edge, ASimulatedRos2RobotIsServedExactly) {
  // No data needed: the simulator publishing PointCloud2 + /tf as a ROS 2 robot does.
  constexpr int kDomain = 183;
  Ros2Server server(serviceOptions(kDomain), ros2Options(), kDomain);
  const std::vector<io::Scan> scans = simScans(6);
  publishAsRos2Robot(kDomain, scans);
  ASSERT_TRUE(server.waitForMapped(scans.size()));
  EXPECT_EQ(server.edge.counters().clouds_waited_out, 0u);
  expectSameMap(*served(server), *offlineOf(asPlacedThroughTf(scans)));
}

TEST(Ros2Edge, SecureWithEnclavesLaidOutAsSros2LaysThemOut) {
  // The server's ROS 2 participant and a ROS 2 robot, each with an identity folder under SROS2's file names
  // (cert.pem, key.pem, identity_ca.cert.pem, permissions_ca.cert.pem, governance.p7s, permissions.p7s).
  constexpr int kDomain = 213;
  Keystore keys("--robots 0 --clients 0 --ros2-robots 1");
  Ros2EdgeOptions o = ros2Options();
  o.security_dir = (keys / "server").string();
  Ros2Server server(serviceOptions(kDomain), o, kDomain);
  msg::DdsOptions d = Ros2TestNode::options(kDomain, "sim_robot");
  d.security_dir = (keys / "ros2-robot-1").string();
  msg::DdsNode robot(d);
  const std::vector<io::Scan> scans = simScans(3);
  client::Ros2PlayOptions play;
  play.wait_s = 20;
  EXPECT_EQ(client::playScans(scans, robot, play).clouds, scans.size());
  ASSERT_TRUE(server.waitForMapped(scans.size()));
  expectSameMap(*served(server), *offlineOf(asPlacedThroughTf(scans)));
  // A ROS 2 robot may not reset the map nor publish the server's map topics.
  const ros2::Qos qos = ros2::Qos::reliableDefault();
  EXPECT_THROW(robot.writer(robot.topic("rq/octomap_server/resetRequest",
                                        msg::rawCdrType("std_srvs::srv::dds_::Empty_Request_")),
                            msg::writerQos(qos)),
               msg::DdsError);
  EXPECT_THROW(robot.writer(robot.topic(ros2::topicOnDds("/octomap_binary"),
                                        msg::rawCdrType(ros2::typeOnDds(ros2::kOctomapType))),
                            msg::writerQos(qos)),
               msg::DdsError);
  // A ROS 2 node without an enclave neither gets the map nor gets its clouds in.
  Ros2TestNode plain(kDomain, "plain_node");
  auto* binary = plain.subscriber("/octomap_binary", ros2::kOctomapType, ros2::Qos{true, false, false, 5});
  client::Ros2PlayOptions brief;
  brief.wait_s = 2;
  client::playScans(simScans(2), plain.node, brief);
  EXPECT_FALSE(Ros2TestNode::take(binary, std::chrono::milliseconds(2000)));
  EXPECT_EQ(Ros2TestNode::matchedCount(binary), 0);
  EXPECT_EQ(server.service.statistics().totals().received, scans.size());
}

TEST(Ros2Edge, OctomapBinaryReadsBackWithOctoMapAndProjectedMapMatchesTheBand) {
  constexpr int kDomain = 184;
  Ros2EdgeOptions ro = ros2Options();
  ro.occupancy_min_z = 0.0;
  ro.occupancy_max_z = 2.0;
  Ros2Server server(serviceOptions(kDomain), ro, kDomain);
  Ros2TestNode tool(kDomain, "rviz2");
  const ros2::Qos qos{true, false, false, 5};
  auto* binary = tool.subscriber("/octomap_binary", ros2::kOctomapType, qos);
  auto* full = tool.subscriber("/octomap_full", ros2::kOctomapType, qos);
  auto* grid = tool.subscriber("/projected_map", ros2::kOccupancyGridType, qos);
  auto* centres = tool.subscriber("/octomap_point_cloud_centers", ros2::kPointCloud2Type, qos);
  const std::vector<io::Scan> scans = simScans(3);
  publishAsRos2Robot(kDomain, scans);
  ASSERT_TRUE(server.waitForMapped(scans.size()));
  // The publications after the last scan: wait two periods, then keep the newest of each.
  std::this_thread::sleep_for(std::chrono::milliseconds(700));
  const auto map = served(server);
  auto newest = [](fdds::DataReader* r) {
    std::optional<std::vector<std::uint8_t>> last;
    while (auto b = Ros2TestNode::take(r, std::chrono::milliseconds(last ? 50 : 3000))) last = std::move(b);
    return last;
  };
  std::optional<ros2::Octomap> bt;
  if (auto b = newest(binary)) bt = ros2::decodeOctomap(*b);
  ASSERT_TRUE(bt);
  EXPECT_TRUE(bt->binary);
  EXPECT_EQ(bt->id, "OcTree");
  EXPECT_EQ(bt->header.frame_id, "map");
  EXPECT_DOUBLE_EQ(bt->resolution, 0.2);
  EXPECT_EQ(std::string(bt->data.begin(), bt->data.end()),
            map::octomapMessageData(*map, map::OctomapFormat::kBinary));
  // octomap_msgs::binaryMsgToMap does this: readBinaryData on the message's data.
  octomap::OcTree tree(bt->resolution);
  std::stringstream in(std::string(bt->data.begin(), bt->data.end()));
  tree.readBinaryData(in);
  ASSERT_TRUE(in.good() || in.eof());
  tree.expand();
  EXPECT_EQ(tree.getNumLeafNodes(), map->knownCells());
  const float threshold = map::OccupancyParams::logOdds(map->params().occupied_threshold);
  std::size_t wrong = 0, occupied = 0;
  map->forEachCell([&](const geometry::VoxelKey& k, float v) {
    const octomap::OcTreeNode* n = tree.search(octomap::OcTreeKey(k[0], k[1], k[2]));
    if (!n || tree.isNodeOccupied(n) != (v >= threshold)) ++wrong;
    if (v >= threshold) ++occupied;
  });
  EXPECT_EQ(wrong, 0u);
  // octomap_full: the log-odds themselves.
  auto f = newest(full);
  ASSERT_TRUE(f);
  const ros2::Octomap ot = ros2::decodeOctomap(*f);
  EXPECT_FALSE(ot.binary);
  octomap::OcTree full_tree(ot.resolution);
  std::stringstream fin(std::string(ot.data.begin(), ot.data.end()));
  full_tree.readData(fin);
  full_tree.expand();
  std::size_t wrong_values = 0;
  map->forEachCell([&](const geometry::VoxelKey& k, float v) {
    const octomap::OcTreeNode* n = full_tree.search(octomap::OcTreeKey(k[0], k[1], k[2]));
    if (!n || n->getLogOdds() != v) ++wrong_values;
  });
  EXPECT_EQ(wrong_values, 0u);
  // projected_map: each column against the served cells whose centres lie in [0, 2] m.
  auto g = newest(grid);
  ASSERT_TRUE(g);
  const ros2::OccupancyGrid og = ros2::decodeOccupancyGrid(*g);
  ASSERT_GT(og.width * og.height, 0u);
  std::vector<std::int8_t> want(og.data.size(), -1);
  std::size_t outside = 0;
  map->forEachCell([&](const geometry::VoxelKey& k, float v) {
    const auto c = map->converter().toCoord(k);
    if (c.z() < 0.0 || c.z() > 2.0) return;
    const long x = std::lround(std::floor((c.x() - og.origin_position[0]) / og.resolution));
    const long y = std::lround(std::floor((c.y() - og.origin_position[1]) / og.resolution));
    if (x < 0 || y < 0 || x >= long(og.width) || y >= long(og.height)) {
      ++outside;
      return;
    }
    std::int8_t& cell = want[std::size_t(y) * og.width + std::size_t(x)];
    if (v >= threshold)
      cell = 100;
    else if (cell != 100)
      cell = 0;
  });
  EXPECT_EQ(outside, 0u);
  EXPECT_EQ(og.data, want);
  EXPECT_GT(std::count(og.data.begin(), og.data.end(), 100), 0);
  EXPECT_GT(std::count(og.data.begin(), og.data.end(), 0), 0);
  // The occupied centres.
  auto pc = newest(centres);
  ASSERT_TRUE(pc);
  EXPECT_EQ(ros2::cloudPoints(ros2::decodePointCloud2(*pc)).points.size(), occupied);
}

TEST(Ros2Edge, ServicesAsRmwFastrtpsCallsThemGetMatchedReplies) {
  constexpr int kDomain = 185;
  Ros2Server server(serviceOptions(kDomain), ros2Options(), kDomain);
  const std::vector<io::Scan> scans = simScans(3);
  publishAsRos2Robot(kDomain, scans);
  ASSERT_TRUE(server.waitForMapped(scans.size()));
  Ros2TestNode client(kDomain, "rqt");
  // A client as rmw_fastrtps makes one: request writer and reply reader, the reader's GUID sent in the
  // request's related_sample_identity so the reply can be matched.
  const ros2::Qos qos = ros2::Qos::reliableDefault();
  auto* rq = client.writer("rq/octomap_server/clear_bboxRequest",
                           "octomap_msgs::srv::dds_::BoundingBoxQuery_Request_", qos);
  auto* rr = client.reader("rr/octomap_server/clear_bboxReply",
                           "octomap_msgs::srv::dds_::BoundingBoxQuery_Response_", qos);
  ASSERT_TRUE(Ros2TestNode::waitMatched(rq));
  ASSERT_TRUE(Ros2TestNode::waitMatched(rr));
  const std::size_t before = served(server)->knownCells();
  const ros2::BoundingBox box{{-2, -2, -1}, {2, 2, 1}};
  auto inBox = [&](const map::OccupancyMap& m) {
    std::size_t n = 0;
    m.forEachCell([&](const geometry::VoxelKey& k, float) {
      const auto c = m.converter().toCoord(k);
      if (c.x() >= -2 && c.x() <= 2 && c.y() >= -2 && c.y() <= 2 && c.z() >= -1 && c.z() <= 1) ++n;
    });
    return n;
  };
  const std::size_t in_box_before = inBox(*served(server));
  ASSERT_GT(in_box_before, 0u);
  eprosima::fastrtps::rtps::WriteParams params;
  params.related_sample_identity().writer_guid(rr->guid());
  msg::RawSample request{ros2::encodeBoundingBoxRequest(box)};
  ASSERT_TRUE(rq->write(&request, params));
  fdds::SampleInfo info;
  auto reply = Ros2TestNode::take(rr, std::chrono::milliseconds(10000), &info);
  ASSERT_TRUE(reply);
  EXPECT_NO_THROW(ros2::decodeEmpty(*reply));
  // rmw_fastrtps's client takes a reply whose related identity is its reader's GUID and its request's number.
  EXPECT_EQ(info.related_sample_identity.writer_guid(), rr->guid());
  EXPECT_EQ(info.related_sample_identity.sequence_number(), params.sample_identity().sequence_number());
  const auto after = served(server);
  EXPECT_EQ(inBox(*after), 0u);
  EXPECT_LE(after->knownCells(), before - in_box_before);
  EXPECT_GT(after->knownCells(), before / 2);  // only the box was cleared

  // GetOctomap on octomap_binary: the same tree the map holds.
  auto* gq = client.writer("rq/octomap_binaryRequest", "octomap_msgs::srv::dds_::GetOctomap_Request_", qos);
  auto* gr = client.reader("rr/octomap_binaryReply", "octomap_msgs::srv::dds_::GetOctomap_Response_", qos);
  ASSERT_TRUE(Ros2TestNode::waitMatched(gq));
  ASSERT_TRUE(Ros2TestNode::waitMatched(gr));
  eprosima::fastrtps::rtps::WriteParams gp;
  gp.related_sample_identity().writer_guid(gr->guid());
  msg::RawSample empty{ros2::encodeEmpty()};
  ASSERT_TRUE(gq->write(&empty, gp));
  auto got = Ros2TestNode::take(gr, std::chrono::milliseconds(10000), &info);
  ASSERT_TRUE(got);
  const ros2::Octomap m = ros2::decodeOctomap(*got);
  const std::string want = map::octomapMessageData(*after, map::OctomapFormat::kBinary);
  EXPECT_EQ(std::string(m.data.begin(), m.data.end()), want);

  // ~/reset forgets the map.
  auto* xq = client.writer("rq/octomap_server/resetRequest", "std_srvs::srv::dds_::Empty_Request_", qos);
  auto* xr = client.reader("rr/octomap_server/resetReply", "std_srvs::srv::dds_::Empty_Response_", qos);
  ASSERT_TRUE(Ros2TestNode::waitMatched(xq));
  ASSERT_TRUE(Ros2TestNode::waitMatched(xr));
  eprosima::fastrtps::rtps::WriteParams xp;
  xp.related_sample_identity().writer_guid(xr->guid());
  ASSERT_TRUE(xq->write(&empty, xp));
  ASSERT_TRUE(Ros2TestNode::take(xr, std::chrono::milliseconds(10000)));
  EXPECT_EQ(served(server)->knownCells(), 0u);
  EXPECT_EQ(server.edge.counters().service_requests, 3u);
}

// An rmw_fastrtps client may send as soon as its own endpoints see the service, before the service's reply
// writer has matched the client's reply reader. The reply must still arrive: the edge waits for that reader.
// Here the reader is enabled (announced) only after the request went out, which forces that order.
TEST(Ros2Edge, AReplyWaitsForItsClientsReaderToBeMatched) {
  constexpr int kDomain = 189;
  Ros2Server server(serviceOptions(kDomain), ros2Options(), kDomain);
  Ros2TestNode client(kDomain, "impatient_client");
  const ros2::Qos qos = ros2::Qos::reliableDefault();
  auto* rq = client.writer("rq/octomap_server/resetRequest", "std_srvs::srv::dds_::Empty_Request_", qos);
  ASSERT_TRUE(Ros2TestNode::waitMatched(rq));
  fdds::SubscriberQos late_qos = fdds::SUBSCRIBER_QOS_DEFAULT;
  late_qos.entity_factory().autoenable_created_entities = false;
  fdds::Subscriber* late = client.node.participant().create_subscriber(late_qos);
  ASSERT_NE(late, nullptr);
  auto* topic = client.node.topic("rr/octomap_server/resetReply",
                                  msg::rawCdrType("std_srvs::srv::dds_::Empty_Response_"));
  fdds::DataReader* rr = late->create_datareader(topic, msg::readerQos(qos));
  ASSERT_NE(rr, nullptr);
  eprosima::fastrtps::rtps::WriteParams params;
  params.related_sample_identity().writer_guid(rr->guid());
  ASSERT_NE(rr->guid(), eprosima::fastrtps::rtps::GUID_t::unknown());
  msg::RawSample empty{ros2::encodeEmpty()};
  ASSERT_TRUE(rq->write(&empty, params));
  std::this_thread::sleep_for(std::chrono::milliseconds(200));  // the edge has the request by now
  ASSERT_EQ(rr->enable(), ReturnCode_t::RETCODE_OK);
  fdds::SampleInfo info;
  ASSERT_TRUE(Ros2TestNode::take(rr, std::chrono::milliseconds(10000), &info));
  EXPECT_EQ(info.related_sample_identity.writer_guid(), rr->guid());
  EXPECT_EQ(info.related_sample_identity.sequence_number(), params.sample_identity().sequence_number());
  EXPECT_EQ(server.edge.counters().service_requests, 1u);
  EXPECT_EQ(server.edge.counters().replies_unmatched, 0u);
  late->delete_contained_entities();
  client.node.participant().delete_subscriber(late);
}

std::vector<std::uint8_t> badCloud(int kind, const io::Scan& scan) {
  std::vector<std::uint8_t> bytes = ros2::scanMessages(scan, 1, "map", "lidar").cloud;
  ros2::PointCloud2 c = ros2::decodePointCloud2(bytes);
  std::vector<std::uint8_t> data(c.data.begin(), c.data.end());
  c.data = data;
  switch (kind) {
    case 0:
      c.is_bigendian = true;
      break;
    case 1:
      c.fields.erase(c.fields.begin() + 2);
      break;  // no z
    case 2:
      c.data = c.data.first(c.data.size() / 2);
      break;  // shorter than row_step * height
    case 3:
      c.row_step = c.point_step * c.width - 4;
      break;  // inconsistent steps
    case 4:
      c.fields[0].datatype = ros2::PointField::kInt16;
      break;
    default:
      return {0x00, 0x01, 0x00, 0x00, 0xFF, 0xFF, 0xFF, 0x7F};  // undecodable CDR
  }
  return ros2::encode(c);
}

TEST(Ros2Edge, BadCloudsAndTransformsAreCountedAndChangeNothing) {
  constexpr int kDomain = 186;
  Ros2Server server(serviceOptions(kDomain), ros2Options(), kDomain);
  const std::vector<io::Scan> scans = simScans(2);
  Ros2TestNode robot(kDomain, "bad_robot");
  auto* clouds = robot.publisher("/cloud_in", ros2::kPointCloud2Type, ros2::Qos::reliableDefault());
  auto* tf = robot.publisher("/tf", ros2::kTfMessageType, ros2::Qos::tf());
  ASSERT_TRUE(Ros2TestNode::waitMatched(clouds));
  ASSERT_TRUE(Ros2TestNode::waitMatched(tf));
  ASSERT_TRUE(server.waitForPublishers());
  // A good scan first: the map it makes must not change afterwards.
  const ros2::ScanMessages good = ros2::scanMessages(scans[0], 1'000'000'000, "map", "lidar");
  Ros2TestNode::write(tf, good.transform);
  Ros2TestNode::write(clouds, good.cloud);
  ASSERT_TRUE(server.waitForMapped(1));
  const auto before = served(server);
  const std::uint64_t version = server.service.mapStore().version();
  for (int kind = 0; kind <= 5; ++kind) Ros2TestNode::write(clouds, badCloud(kind, scans[1]));
  // Bad transforms: NaN, a zero quaternion, a loop, undecodable bytes. Then a cloud that needs them.
  auto transform = [](const std::string& parent, const std::string& child, ros2::Vector3 t,
                      ros2::Quaternion q) {
    ros2::TransformStamped s;
    s.header.frame_id = parent;
    s.header.stamp = ros2::Time::fromNanoseconds(2'000'000'000);
    s.child_frame_id = child;
    s.translation = t;
    s.rotation = q;
    return ros2::encode(ros2::TfMessage{{s}});
  };
  const double nan = std::numeric_limits<double>::quiet_NaN();
  Ros2TestNode::write(tf, transform("map", "lidar", {nan, 0, 0}, {}));
  Ros2TestNode::write(tf, transform("map", "lidar", {0, 0, 0}, {0, 0, 0, 0}));
  Ros2TestNode::write(tf, transform("lidar", "map", {0, 0, 0}, {}));
  Ros2TestNode::write(tf, {0x00, 0x01, 0x00, 0x00, 0x05});
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (std::chrono::steady_clock::now() < until) {
    const auto c = server.edge.counters();
    if (c.clouds_undecodable >= 6 && c.tf_refused + c.tf_undecodable >= 4) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  const auto c = server.edge.counters();
  EXPECT_EQ(c.clouds_undecodable, 6u);
  EXPECT_EQ(c.tf_refused, 3u);
  EXPECT_EQ(c.tf_undecodable, 1u);
  EXPECT_EQ(server.service.mapStore().version(), version);
  expectSameMap(*served(server), *before);
}

TEST(Ros2Edge, ACloudWaitsForItsTransformAndIsDroppedWhenItNeverComes) {
  constexpr int kDomain = 187;
  Ros2EdgeOptions ro = ros2Options();
  ro.tf_timeout_s = 0.5;
  Ros2Server server(serviceOptions(kDomain), ro, kDomain);
  const std::vector<io::Scan> scans = simScans(2);
  Ros2TestNode robot(kDomain, "late_tf_robot");
  auto* clouds = robot.publisher("/cloud_in", ros2::kPointCloud2Type, ros2::Qos::reliableDefault());
  auto* tf = robot.publisher("/tf", ros2::kTfMessageType, ros2::Qos::tf());
  ASSERT_TRUE(Ros2TestNode::waitMatched(clouds));
  ASSERT_TRUE(Ros2TestNode::waitMatched(tf));
  ASSERT_TRUE(server.waitForPublishers());
  // Cloud first, its transform 200 ms later: the cloud waits (tf2's message filter) and is mapped.
  const ros2::ScanMessages first = ros2::scanMessages(scans[0], 1'000'000'000, "map", "lidar");
  Ros2TestNode::write(clouds, first.cloud);
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  EXPECT_EQ(server.service.statistics().totals().processed, 0u);
  Ros2TestNode::write(tf, first.transform);
  ASSERT_TRUE(server.waitForMapped(1, std::chrono::seconds(10)));
  EXPECT_GE(server.edge.counters().tf_wait_ms.max_ms, 150.0);
  // A cloud whose transform never comes: dropped after the timeout, counted, the map unchanged.
  const std::uint64_t version = server.service.mapStore().version();
  Ros2TestNode::write(clouds, ros2::scanMessages(scans[1], 5'000'000'000, "map", "lidar").cloud);
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (server.edge.counters().clouds_waited_out == 0 && std::chrono::steady_clock::now() < until)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  EXPECT_EQ(server.edge.counters().clouds_waited_out, 1u);
  EXPECT_EQ(server.service.mapStore().version(), version);
}

TEST(Ros2Edge, APoseTopicInsteadOfTf) {
  constexpr int kDomain = 188;
  Ros2EdgeOptions ro = ros2Options();
  ro.frames.pose_topic = "/odom";
  ro.pose_type = "odometry";
  Ros2Server server(serviceOptions(kDomain), ro, kDomain);
  const std::vector<io::Scan> scans = simScans(2);
  Ros2TestNode robot(kDomain, "odom_robot");
  auto* clouds = robot.publisher("/cloud_in", ros2::kPointCloud2Type, ros2::Qos::sensorData());
  auto* odom = robot.publisher("/odom", ros2::kOdometryType, ros2::Qos::reliableDefault());
  ASSERT_TRUE(Ros2TestNode::waitMatched(clouds));
  ASSERT_TRUE(Ros2TestNode::waitMatched(odom));
  ASSERT_TRUE(server.waitForPublishers());
  for (std::size_t i = 0; i < scans.size(); ++i) {
    const std::int64_t stamp = 1'000'000'000 * std::int64_t(i + 1);
    ros2::PoseStamped p;
    p.header.frame_id = "map";
    p.header.stamp = ros2::Time::fromNanoseconds(stamp);
    p.child_frame_id = "lidar";
    const Eigen::Vector3d t = scans[i].pose.translation();
    const Eigen::Quaterniond q(scans[i].pose.rotation());
    p.position = {t.x(), t.y(), t.z()};
    p.orientation = {q.x(), q.y(), q.z(), q.w()};
    Ros2TestNode::write(odom, ros2::encodeOdometry(p));
    Ros2TestNode::write(clouds, ros2::scanMessages(scans[i], stamp, "map", "lidar").cloud);
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  ASSERT_TRUE(server.waitForMapped(scans.size(), std::chrono::seconds(20)));
  expectSameMap(*served(server), *offlineOf(asPlacedThroughTf(scans)));
}

}  // namespace
}  // namespace densemap::test
