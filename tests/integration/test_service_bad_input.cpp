// Bad input gets an error status or a rejection counter, the server stays up, and rejected input leaves
// the map unchanged: after every case the served map still equals the offline map of the accepted scans.
#include <cstring>
#include <limits>
#include <thread>

#include <filesystem>

#include <gtest/gtest.h>

#include "densemap/msg/checked_type.h"
#include "densemap/msg/peer_topic.h"
#include "service_harness.h"

namespace densemap::test {
namespace {

/// A well-formed message for scan `s` (sensor frame), to be broken by each case.
msg::Scan message(const io::Scan& s, const std::string& robot, std::uint64_t seq) {
  return client::toMessage(robot, seq, s);
}

class BadInput : public ::testing::Test {
 protected:
  void start(int domain) {
    auto o = serverOptions(domain);
    o.limits.max_points = 20'000;
    h_ = std::make_unique<ServiceHarness>(o);
    scans_ = simScans(3);
    ASSERT_EQ(h_->replay({scans_[0]}).applied, 1u);
    accepted_ = {scans_[0]};
  }
  /// Sends a broken message; expects the given outcome in its acknowledgement.
  msg::ScanAck send(msg::Scan m) {
    EXPECT_TRUE(h_->robot->publishRaw(m));
    h_->robot->waitForAcks({m.robot_id()}, ++sent_[m.robot_id()], 30s);
    auto ack = h_->robot->ack(m.robot_id(), m.seq());
    EXPECT_TRUE(ack.has_value()) << "no acknowledgement for " << m.robot_id() << "#" << m.seq();
    return ack.value_or(msg::ScanAck());
  }
  void expectRejectedAndUnchanged(const msg::ScanAck& ack, const std::string& what) {
    EXPECT_EQ(ack.outcome(), msg::SCAN_REJECTED) << what;
    EXPECT_FALSE(ack.message().empty()) << what << ": a rejection must say why";
    expectServedEquals(*h_, *offlineMap<map::GridMap>(accepted_, 0.2));
  }

  std::unique_ptr<ServiceHarness> h_;
  std::vector<io::Scan> scans_, accepted_;
  std::map<std::string, std::uint64_t> sent_{{"robot-0", 1}};
};

TEST_F(BadInput, NonFinitePointsAreDroppedAndCountedTheRestIsMapped) {
  start(130);
  msg::Scan m = message(scans_[1], "robot-0", 1);
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  m.points()[0] = nan;
  m.points()[4] = inf;
  m.points()[8] = -inf;
  const auto ack = send(m);
  EXPECT_EQ(ack.outcome(), msg::SCAN_APPLIED) << ack.message();
  EXPECT_EQ(ack.points_rejected(), 3u);
  io::Scan filtered = scans_[1];
  filtered.points.erase(filtered.points.begin(), filtered.points.begin() + 3);
  accepted_.push_back(filtered);
  expectServedEquals(*h_, *offlineMap<map::GridMap>(accepted_, 0.2));
}

TEST_F(BadInput, AScanLabelledAnotherRobotIsRejectedAsTheSendersOwn) {
  start(221);
  // robot-0's topic names the sender: a scan on it that says robot-9 is refused, acknowledged to robot-0
  // and counted as robot-0's; robot-9's counters do not move.
  msg::Scan m = message(scans_[1], "robot-9", 1);
  ASSERT_TRUE(h_->robot->publishRaw(m, "robot-0"));
  h_->robot->waitForAcks({"robot-0"}, 2, 30s);
  const auto ack = h_->robot->ack("robot-0", 1);
  ASSERT_TRUE(ack.has_value()) << "no acknowledgement on robot-0's topic";
  expectRejectedAndUnchanged(*ack, "a scan labelled another robot");
  EXPECT_NE(ack->message().find("only its own scans"), std::string::npos) << ack->message();
  for (const auto& [id, c] : h_->server->service.statistics().robots) {
    EXPECT_NE(id, "robot-9") << "the label's robot was counted";
    if (id == "robot-0") {
      EXPECT_EQ(c.rejected, 1u);
    }
  }
  EXPECT_FALSE(h_->robot->ack("robot-9", 1).has_value());
}

TEST_F(BadInput, EmptyAllNanAndOversizedScansAreRejected) {
  start(131);
  msg::Scan empty = message(scans_[1], "robot-0", 1);
  empty.points().clear();
  expectRejectedAndUnchanged(send(empty), "empty scan");
  msg::Scan all_nan = message(scans_[1], "robot-0", 2);
  for (auto& v : all_nan.points()) v = std::numeric_limits<float>::quiet_NaN();
  expectRejectedAndUnchanged(send(all_nan), "all-NaN scan");
  msg::Scan big = message(scans_[1], "robot-0", 3);
  while (big.points().size() / 3 <= 20'000) big.points().insert(big.points().end(), {1.f, 2.f, 3.f});
  expectRejectedAndUnchanged(send(big), "scan over the point limit");
  msg::Scan ragged = message(scans_[1], "robot-0", 4);
  ragged.points().pop_back();
  expectRejectedAndUnchanged(send(ragged), "points not packed x y z");
  const auto stats = h_->server->statistics();
  ASSERT_EQ(stats.robots().size(), 1u);
  EXPECT_EQ(stats.robots()[0].rejected(), 4u);
  EXPECT_EQ(stats.robots()[0].processed(), 1u);
}

TEST_F(BadInput, BadPosesAreRejected) {
  start(132);
  msg::Scan twice = message(scans_[1], "robot-0", 1);
  twice.sensor_pose().qw(2.0 * twice.sensor_pose().qw());
  twice.sensor_pose().qx(2.0 * twice.sensor_pose().qx());
  twice.sensor_pose().qy(2.0 * twice.sensor_pose().qy());
  twice.sensor_pose().qz(2.0 * twice.sensor_pose().qz());
  expectRejectedAndUnchanged(send(twice), "non-unit quaternion");
  msg::Scan zero = message(scans_[1], "robot-0", 2);
  zero.sensor_pose().qw(0);
  zero.sensor_pose().qx(0);
  zero.sensor_pose().qy(0);
  zero.sensor_pose().qz(0);
  expectRejectedAndUnchanged(send(zero), "zero quaternion");
  msg::Scan nan_pose = message(scans_[1], "robot-0", 3);
  nan_pose.sensor_pose().px(std::numeric_limits<double>::quiet_NaN());
  expectRejectedAndUnchanged(send(nan_pose), "NaN position");
  msg::Scan far = message(scans_[1], "robot-0", 4);
  far.sensor_pose().px(1e7);  // beyond the 0.2 m map's key range (+-6553.6 m)
  expectRejectedAndUnchanged(send(far), "origin outside the key range");
}

TEST_F(BadInput, PointsBeyondTheKeyRangeAreDroppedAndCounted) {
  start(133);
  msg::Scan m = message(scans_[1], "robot-0", 1);
  m.points()[0] = 1e6f;  // first point 1000 km away
  const auto ack = send(m);
  EXPECT_EQ(ack.outcome(), msg::SCAN_APPLIED) << ack.message();
  EXPECT_EQ(ack.points_rejected(), 1u);
  io::Scan kept = scans_[1];
  kept.points.erase(kept.points.begin());
  accepted_.push_back(kept);
  expectServedEquals(*h_, *offlineMap<map::GridMap>(accepted_, 0.2));
}

TEST_F(BadInput, MalformedQueriesGetAnErrorStatusAndTheServerStaysUp) {
  start(134);
  auto expectStatus = [&](msg::QueryRequest rq, msg::QueryStatus want, const std::string& what) {
    const auto r = h_->query->call(rq, 30s);
    EXPECT_EQ(r.status(), want) << what << ": " << r.message();
    EXPECT_FALSE(r.message().empty()) << what;
  };
  msg::QueryRequest unknown;
  unknown.kind(static_cast<msg::QueryKind>(99));
  expectStatus(unknown, msg::STATUS_UNKNOWN_KIND, "unknown kind");
  expectStatus(client::boxRequest(msg::QUERY_BOX, {1, 1, 1}, {0, 2, 2}), msg::STATUS_INVALID_ARGUMENT,
               "inverted box");
  msg::QueryRequest ragged;
  ragged.kind(msg::QUERY_POINTS);
  ragged.points({1.f, 2.f});
  expectStatus(ragged, msg::STATUS_INVALID_ARGUMENT, "points not x y z");
  msg::QueryRequest ray;
  ray.kind(msg::QUERY_RAY);
  ray.max_range(10);
  expectStatus(ray, msg::STATUS_INVALID_ARGUMENT, "zero ray direction");
  msg::QueryRequest layer;
  layer.kind(msg::QUERY_STATS);
  layer.layer(static_cast<msg::MapLayer>(7));
  expectStatus(layer, msg::STATUS_INVALID_ARGUMENT, "unknown layer");
  // Commands, on their own topic, are checked the same way.
  auto expectRefused = [&](const msg::AdminRequest& rq, msg::QueryStatus want, const char* what) {
    const auto r = h_->admin->call(rq, 30s);
    EXPECT_EQ(r.status(), want) << what << ": " << r.message();
    EXPECT_FALSE(r.message().empty()) << what;
  };
  expectRefused(client::clearBoxRequest({0, 0, 5}, {1, 1, 1}), msg::STATUS_INVALID_ARGUMENT,
                "inverted clear box");
  expectRefused(client::saveRequest("map.txt"), msg::STATUS_INVALID_ARGUMENT, "save with a wrong extension");
  expectRefused(client::saveRequest("/etc/densemap-test.bt"), msg::STATUS_INVALID_ARGUMENT, "save to a path");
  expectRefused(client::saveRequest("../escape.bt"), msg::STATUS_INVALID_ARGUMENT, "save out of the map dir");
  expectRefused(client::loadRequest("missing.ot"), msg::STATUS_NOT_FOUND, "load of a missing map");
  msg::AdminRequest unknown_command;
  unknown_command.kind(static_cast<msg::AdminKind>(42));
  expectRefused(unknown_command, msg::STATUS_UNKNOWN_KIND, "unknown command");
  EXPECT_FALSE(std::filesystem::exists("/etc/densemap-test.bt"));
  // Still serving, map untouched.
  expectServedEquals(*h_, *offlineMap<map::GridMap>(accepted_, 0.2));
  const auto stats = h_->server->statistics();
  EXPECT_EQ(stats.queries_failed(), 5u);
  EXPECT_EQ(stats.commands_failed(), 6u);
}

/// Writes arbitrary bytes as samples of a topic's type (same type name, no decoding): what a broken or
/// hostile participant on the domain can send.
class RawBytesType : public eprosima::fastdds::dds::TopicDataType {
 public:
  explicit RawBytesType(const std::string& type_name) {
    setName(type_name.c_str());
    m_typeSize = 1 << 16;
    m_isGetKeyDefined = false;
  }
  bool serialize(void* data, eprosima::fastrtps::rtps::SerializedPayload_t* payload) override {
    const auto& bytes = *static_cast<const std::string*>(data);
    if (bytes.size() > payload->max_size) return false;
    std::memcpy(payload->data, bytes.data(), bytes.size());
    payload->length = static_cast<std::uint32_t>(bytes.size());
    return true;
  }
  bool deserialize(eprosima::fastrtps::rtps::SerializedPayload_t*, void*) override { return false; }
  std::function<std::uint32_t()> getSerializedSizeProvider(void* data) override {
    return [data] { return static_cast<std::uint32_t>(static_cast<const std::string*>(data)->size()); };
  }
  void* createData() override { return nullptr; }  // write-only
  void deleteData(void*) override {}
  bool getKey(void*, eprosima::fastrtps::rtps::InstanceHandle_t*, bool) override { return false; }
};

TEST_F(BadInput, UndecodableDdsSamplesAreRefusedAndCountedTheServerStaysUp) {
  start(136);
  msg::DdsOptions dds;
  dds.domain = 136;
  dds.loopback = true;
  dds.name = "hostile";
  msg::DdsNode node(dds);
  auto* topic = node.topic(
      msg::peerTopicOf(msg::kScanTopic, "hostile"),  // a robot the server has not seen: it makes its reader
      eprosima::fastdds::dds::TypeSupport(
          std::make_unique<RawBytesType>("densemap::msg::Scan_v1").release()));
  auto* writer = node.writer(topic, msg::kScanWriterProfile);
  ASSERT_NE(writer, nullptr);
  const auto deadline = std::chrono::steady_clock::now() + 20s;
  eprosima::fastdds::dds::PublicationMatchedStatus matched;
  while (writer->get_publication_matched_status(matched) == ReturnCode_t::RETCODE_OK &&
         matched.current_count == 0 && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(20ms);
  ASSERT_GT(matched.current_count, 0) << "the raw writer did not match the server's scan reader";
  const std::uint64_t before = msg::undecodableSamples();
  // Not CDR at all (first encapsulation byte non-zero: Fast CDR throws), a CDR header and nothing else, and
  // a string claiming 2^31 bytes.
  std::vector<std::string> samples = {std::string("\x7f\x01\x00\x00garbage", 11),
                                      std::string("\x00\x01\x00\x00", 4),
                                      std::string("\x00\x01\x00\x00\x00\x00\x00\x80xx", 10)};
  for (auto& s : samples) ASSERT_TRUE(writer->write(&s));
  while (msg::undecodableSamples() < before + samples.size() && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(20ms);
  EXPECT_EQ(msg::undecodableSamples(), before + samples.size());
  node.remove(writer);
  // Still serving: a good scan is mapped and acknowledged, the map holds exactly the accepted scans.
  EXPECT_EQ(h_->replay({scans_[1]}, "robot-0", 1).applied, 2u);  // seq 0 (start) and 1
  accepted_.push_back(scans_[1]);
  expectServedEquals(*h_, *offlineMap<map::GridMap>(accepted_, 0.2));
  EXPECT_EQ(h_->server->statistics().samples_undecodable(), msg::undecodableSamples());
}

// An endpoint whose topic lies under a per-peer base but names no valid id as densemap writes ids (here a
// robot id with its '-' unescaped, which Fast DDS takes and Cyclone DDS 0.10 would refuse): ignored, counted,
// never given a reader; the server goes on.
TEST_F(BadInput, APeerTopicThatNamesNoValidIdIsIgnoredAndCounted) {
  start(56);
  msg::DdsOptions dds;
  dds.domain = 56;
  dds.loopback = true;
  dds.name = "unescaped";
  msg::DdsNode node(dds);
  auto* topic = node.topic(std::string(msg::kScanTopic) + "/robot-9",
                           eprosima::fastdds::dds::TypeSupport(
                               std::make_unique<RawBytesType>("densemap::msg::Scan_v1").release()));
  auto* writer = node.writer(topic, msg::kScanWriterProfile);
  ASSERT_NE(writer, nullptr);
  // The DDS edge's count (what its statistics message carries as peer_topics_refused).
  auto refused = [&] { return h_->server->edge.peerTopicsRefused(); };
  const auto deadline = std::chrono::steady_clock::now() + 10s;
  while (refused() == 0 && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(20ms);
  EXPECT_EQ(refused(), 1u);
  std::this_thread::sleep_for(500ms);
  eprosima::fastdds::dds::PublicationMatchedStatus matched;
  writer->get_publication_matched_status(matched);
  EXPECT_EQ(matched.current_count, 0) << "the server made a scan reader for an invalid peer topic";
  node.remove(writer);
  EXPECT_EQ(h_->replay({scans_[1]}, "robot-0", 1).applied, 2u);
}

TEST_F(BadInput, ClearBoxAndResetChangeOnlyWhatTheyAsk) {
  start(135);
  const auto before = h_->stats().stats();
  const auto r = h_->admin->call(client::clearBoxRequest({-12, -3, -1}, {-8, 3, 3}), 30s);
  ASSERT_EQ(r.status(), msg::STATUS_OK) << r.message();
  auto offline = offlineMap<map::GridMap>(accepted_, 0.2);
  geometry::VoxelKey lo, hi;
  offline->converter().toKey(geometry::Vec3f(-12, -3, -1), lo);
  offline->converter().toKey(geometry::Vec3f(-8, 3, 3), hi);
  const std::size_t erased = offline->eraseBox(lo, hi);
  EXPECT_GT(erased, 0u);
  EXPECT_EQ(r.cells_changed(), erased);
  expectServedEquals(*h_, *offline);
  const auto rr = h_->admin->call(client::resetRequest(), 30s);
  ASSERT_EQ(rr.status(), msg::STATUS_OK) << rr.message();
  EXPECT_EQ(rr.cells_changed(), before.known_cells() - erased);
  EXPECT_EQ(h_->stats().stats().known_cells(), 0u);
}

}  // namespace
}  // namespace densemap::test
