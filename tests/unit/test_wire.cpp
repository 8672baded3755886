// The DDS edge's wire conversions (server/dds_edge/src/wire.cpp), without a participant: every message
// kind to the service's types and back, and the malformed ones turned into error answers.
#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "densemap/server/dds_edge/wire.h"

namespace densemap::test {
namespace {

using namespace server;
using namespace server::dds_edge;

TEST(Wire, ScansConvertAndRaggedPointsAreNamed) {
  msg::Scan m;
  m.robot_id("r7");
  m.seq(42);
  m.publish_ns(123);
  m.frame_id("world");
  m.sensor_pose().px(1.0);
  m.sensor_pose().qw(1.0);
  m.points({1, 2, 3, 4, 5, 6});
  m.lidar().rows(16);
  m.lidar().columns(512);
  std::string why;
  const ScanJob job = toScanJob(m, why);
  EXPECT_TRUE(why.empty());
  EXPECT_EQ(job.robot_id, "r7");
  EXPECT_EQ(job.seq, 42u);
  EXPECT_EQ(job.publish_ns, 123);
  EXPECT_EQ(job.scan.frame, io::PointFrame::kWorld);
  ASSERT_EQ(job.scan.points.size(), 2u);
  EXPECT_EQ(job.scan.points[1], geometry::Vec3f(4, 5, 6));
  EXPECT_EQ(job.position[0], 1.0);
  ASSERT_TRUE(job.scan.lidar);
  EXPECT_EQ(job.scan.lidar->rows, 16);
  m.points().pop_back();
  toScanJob(m, why);
  EXPECT_NE(why.find("x y z"), std::string::npos) << why;
}

TEST(Wire, AcksCarryTheOutcome) {
  ScanJob job;
  job.robot_id = "r1";
  job.seq = 5;
  job.scan.points.resize(10);
  job.points_rejected = 3;
  job.map_version = 9;
  job.in_map_ns = 77;
  const msg::ScanAck in_map = toAck(job, ScanOutcome::kInMap, "");
  EXPECT_EQ(in_map.outcome(), msg::SCAN_APPLIED);
  EXPECT_EQ(in_map.points_used(), 7u);
  EXPECT_EQ(in_map.map_version(), 9u);
  EXPECT_EQ(in_map.done_ns(), 77);
  const msg::ScanAck dropped = toAck(job, ScanOutcome::kDropped, "queue full");
  EXPECT_EQ(dropped.outcome(), msg::SCAN_DROPPED);
  EXPECT_EQ(dropped.message(), "queue full");
  EXPECT_EQ(toAck(job, ScanOutcome::kRejected, "bad").outcome(), msg::SCAN_REJECTED);
}

TEST(Wire, EveryQueryKindConverts) {
  msg::QueryRequest rq;
  rq.kind(msg::QUERY_POINTS);
  rq.layer(msg::LAYER_FUSED);
  rq.points({1, 2, 3});
  auto q = toQuery(rq);
  ASSERT_TRUE(std::holds_alternative<Query>(q));
  const auto& points = std::get<PointsQuery>(std::get<Query>(q));
  EXPECT_EQ(points.layer, Layer::kFused);
  ASSERT_EQ(points.points.size(), 1u);
  rq.kind(msg::QUERY_BOX);
  rq.box_min({1, 2, 3});
  rq.box_max({4, 5, 6});
  rq.limit(8);
  q = toQuery(rq);
  const auto& box = std::get<BoxQuery>(std::get<Query>(q));
  EXPECT_EQ(box.max, Vec3f(4, 5, 6));
  EXPECT_EQ(box.limit, 8u);
  rq.kind(msg::QUERY_RAY);
  rq.ray_direction({0, 0, 1});
  rq.max_range(12.5f);
  rq.ignore_unknown(true);
  q = toQuery(rq);
  const auto& ray = std::get<RayQuery>(std::get<Query>(q));
  EXPECT_EQ(ray.direction, Vec3f(0, 0, 1));
  EXPECT_TRUE(ray.ignore_unknown);
  EXPECT_EQ(ray.max_range, 12.5f);
  rq.kind(msg::QUERY_STATS);
  EXPECT_TRUE(std::holds_alternative<StatsQuery>(std::get<Query>(toQuery(rq))));
}

TEST(Wire, MalformedQueriesBecomeErrorAnswers) {
  msg::QueryRequest rq;
  rq.kind(static_cast<msg::QueryKind>(99));
  EXPECT_EQ(std::get<Answer>(toQuery(rq)).status, Status::kUnknownKind);
  rq.kind(msg::QUERY_POINTS);
  rq.points({1, 2});
  EXPECT_EQ(std::get<Answer>(toQuery(rq)).status, Status::kInvalidArgument);
  rq.points({});
  rq.layer(static_cast<msg::MapLayer>(9));
  const Answer a = std::get<Answer>(toQuery(rq));
  EXPECT_EQ(a.status, Status::kInvalidArgument);
  EXPECT_NE(a.message.find("layer"), std::string::npos);
}

TEST(Wire, AnswersConvertToReplies) {
  msg::QueryRequest rq;
  rq.client_id("c");
  rq.request_id(3);
  rq.kind(msg::QUERY_POINTS);
  Answer a;
  a.map_version = 11;
  a.result = PointsAnswer{{0.2f, 0.9f, 0.5f}, {CellState::kFree, CellState::kOccupied, CellState::kUnknown}};
  msg::QueryReply rp = toReply(rq, a);
  EXPECT_EQ(rp.client_id(), "c");
  EXPECT_EQ(rp.request_id(), 3u);
  EXPECT_EQ(rp.status(), msg::STATUS_OK);
  EXPECT_EQ(rp.map_version(), 11u);
  EXPECT_EQ(rp.states(), (std::vector<std::uint8_t>{msg::CELL_FREE, msg::CELL_OCCUPIED, msg::CELL_UNKNOWN}));
  a.result = BoxAnswer{{Vec3f(1, 2, 3)}, true, 7};
  rp = toReply(rq, a);
  EXPECT_EQ(rp.cells(), (std::vector<float>{1, 2, 3}));
  EXPECT_TRUE(rp.truncated());
  EXPECT_EQ(rp.blocks_not_in_memory(), 7u);
  a.result = RayAnswer{true, Vec3f(4, 5, 6)};
  rp = toReply(rq, a);
  EXPECT_TRUE(rp.hit());
  EXPECT_EQ(rp.hit_point()[2], 6.0f);
  EXPECT_FALSE(rp.ray_reached_not_in_memory());
  a.result = RayAnswer{false, Vec3f::Zero(), true};
  EXPECT_TRUE(toReply(rq, a).ray_reached_not_in_memory());
  MapSummary s;
  s.known_cells = 10;
  s.bounds_max = Vec3f(1, 1, 1);
  a.result = s;
  EXPECT_EQ(toReply(rq, a).stats().known_cells(), 10u);
  for (const Status st : {Status::kInvalidArgument, Status::kUnknownKind, Status::kLayerUnavailable,
                          Status::kFailed, Status::kNotFound, Status::kUnavailable}) {
    a.status = st;
    EXPECT_NE(toReply(rq, a).status(), msg::STATUS_OK) << toString(st);
  }
}

TEST(Wire, CommandsConvertAndUnknownOnesAreRefused) {
  msg::AdminRequest rq;
  rq.kind(msg::ADMIN_PING);
  EXPECT_TRUE(std::holds_alternative<std::monostate>(toCommand(rq)));
  rq.kind(msg::ADMIN_SAVE);
  rq.name("a.bt");
  EXPECT_EQ(std::get<SaveCommand>(std::get<Command>(toCommand(rq))).name, "a.bt");
  rq.kind(msg::ADMIN_LOAD);
  EXPECT_EQ(std::get<LoadCommand>(std::get<Command>(toCommand(rq))).name, "a.bt");
  rq.kind(msg::ADMIN_CLEAR_BOX);
  rq.box_min({-1, -1, -1});
  EXPECT_EQ(std::get<ClearBoxCommand>(std::get<Command>(toCommand(rq))).min, Vec3f(-1, -1, -1));
  rq.kind(msg::ADMIN_RESET);
  EXPECT_TRUE(std::holds_alternative<ResetCommand>(std::get<Command>(toCommand(rq))));
  rq.kind(static_cast<msg::AdminKind>(50));
  EXPECT_EQ(std::get<CommandResult>(toCommand(rq)).status, Status::kUnknownKind);
  CommandResult r;
  r.cells_changed = 4;
  r.map = MapSummary{};
  r.map->known_cells = 12;
  const msg::AdminReply rp = toReply(rq, r);
  EXPECT_EQ(rp.cells_changed(), 4u);
  EXPECT_EQ(rp.stats().known_cells(), 12u);
}

TEST(Wire, StatisticsConvert) {
  ServiceStatistics s;
  s.server_id = "srv";
  RobotCounters c;
  c.received = 5;
  c.processed = 4;
  c.rejected = 1;
  s.robots.emplace_back("r0", c);
  StageCounters st;
  st.name = "occupancy";
  st.latency.p99_ms = 3.5;
  s.stages.push_back(st);
  s.queries_answered = 8;
  s.commands_failed = 2;
  s.map_version = 4;
  const msg::ServerStatistics m = toWire(s);
  EXPECT_EQ(m.server_id(), "srv");
  ASSERT_EQ(m.robots().size(), 1u);
  EXPECT_EQ(m.robots()[0].robot_id(), "r0");
  EXPECT_EQ(m.robots()[0].rejected(), 1u);
  ASSERT_EQ(m.stages().size(), 1u);
  EXPECT_EQ(m.stages()[0].latency_p99_ms(), 3.5);
  EXPECT_EQ(m.queries_answered(), 8u);
  EXPECT_EQ(m.commands_failed(), 2u);
  EXPECT_EQ(m.map_stats().map_version(), 4u);
  EXPECT_FALSE(m.window().enabled()) << "no window";
  s.window = MapWindowStats{3, 10, 7, 0, 4096, 1, 2, 5, 6, 9};
  const msg::ServerStatistics w = toWire(s);
  EXPECT_TRUE(w.window().enabled());
  EXPECT_EQ(w.window().blocks_out_of_memory(), 3u);
  EXPECT_EQ(w.window().blocks_evicted(), 10u);
  EXPECT_EQ(w.window().blocks_returned(), 7u);
  EXPECT_EQ(w.window().bytes_stored(), 4096u);
  EXPECT_EQ(w.window().store_failures(), 1u);
  EXPECT_EQ(w.window().robots_forgotten(), 2u);
  EXPECT_EQ(w.window().blocks_loaded_for_queries(), 5u);
  EXPECT_EQ(w.window().query_load_failures(), 6u);
  EXPECT_EQ(w.window().dense_blocks_dropped(), 9u);
}

TEST(Wire, AnotherServersStartIsReadOnlyFromPlausibleStatistics) {
  msg::ServerStatistics m;
  m.stamp_ns(2'000'000'000'000);
  m.uptime_s(1.5);
  EXPECT_EQ(serverStartNs(m), std::optional<std::int64_t>(1'998'500'000'000));
  for (const double bad : {std::nan(""), -1.0, 1e300}) {
    m.uptime_s(bad);
    EXPECT_FALSE(serverStartNs(m).has_value()) << bad;
  }
  m.uptime_s(1.0);
  m.stamp_ns(std::numeric_limits<std::int64_t>::max());
  EXPECT_FALSE(serverStartNs(m).has_value());
}

}  // namespace
}  // namespace densemap::test
