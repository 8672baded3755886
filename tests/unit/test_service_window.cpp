// The rolling window and the memory cap in the service: blocks far from the robots or past the
// cap leave memory, come back when a scan reaches them, and the map stays the map of every scan: each cell
// answers exactly the offline map's value, or says it is stored out of memory. Also across a restart.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>

#include <spdlog/sinks/ostream_sink.h>
#include <spdlog/spdlog.h>

#include "densemap/io/scan_source.h"
#include "densemap/map/grid_map.h"
#include "densemap/server/map_service.h"
#include "map_service_helpers.h"
#include "temp_dir.h"

namespace densemap::test {
namespace {

using namespace server;
namespace fs = std::filesystem;

ServiceOptions windowOptions(const fs::path& dir) {
  ServiceOptions o;
  o.data_dir = (dir / "data").string();
  o.map_dir = (dir / "maps").string();
  o.update_nice = 0;
  o.durability.journal_sync_ms = 2;
  o.durability.snapshot_every_scans = 0;
  o.durability.snapshot_every_s = 0;
  o.window.radius_m = 20.0;  // the simulator drives 2 m per scan: blocks leave after a few scans
  return o;
}

/// Forward along the street, then back to the start: the way back needs the blocks that left.
std::vector<io::Scan> thereAndBack(int n) {
  io::LidarSimulator sim(smallSimulator(n, 32, 512, 2.0));
  std::vector<io::Scan> out;
  for (int i = 0; i < n; ++i) out.push_back(sim.read(static_cast<std::size_t>(i)));
  for (int i = n - 1; i >= 0; --i) out.push_back(sim.read(static_cast<std::size_t>(i)));
  return out;
}

void submitAll(MapService& s, const std::vector<io::Scan>& scans, std::size_t from, std::size_t to) {
  Outcomes out;
  for (std::size_t i = from; i < to; ++i)
    EXPECT_TRUE(s.submit(jobOf(scans[i], "r0", i), out.callback()).accepted);
  ASSERT_TRUE(out.waitFor(to - from));
  EXPECT_EQ(out.count(ScanOutcome::kInMap), to - from) << out.lastWhy();
}

struct Tally {
  std::size_t same = 0, stored = 0, wrong = 0;
};

/// Every known cell of `expected` (its centre as a point query): the same probability and state, or "not
/// in memory".
Tally compare(MapService& s, const map::OccupancyMap& expected) {
  std::vector<geometry::Vec3f> points;
  std::vector<float> want;
  expected.forEachCell([&](const geometry::VoxelKey& k, float v) {
    points.push_back(expected.converter().toCoord(k));
    want.push_back(map::OccupancyParams::probability(v));
  });
  const Answer a = s.answer(PointsQuery{points});
  Tally t;
  const auto& p = std::get<PointsAnswer>(a.result);
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (p.states[i] == CellState::kNotInMemory) {
      ++t.stored;
    } else if (p.probabilities[i] == want[i]) {
      ++t.same;
    } else {
      ++t.wrong;
    }
  }
  return t;
}

/// A window of 20 m over the simulator driven there and back (12 scans each way).
class ServiceWindow : public ::testing::Test {
 protected:
  TempDir tmp;
  ServiceOptions o = windowOptions(tmp.path);
  const std::vector<io::Scan> scans = thereAndBack(12);
  const std::size_t forward = scans.size() / 2;

  /// compare() against the offline map of the first `n` scans.
  Tally compareFirst(MapService& s, std::size_t n) const {
    return compare(s, *offline({scans.begin(), scans.begin() + static_cast<std::ptrdiff_t>(n)}, o.map));
  }
};

TEST_F(ServiceWindow, FarBlocksLeaveAndComeBackAndEveryCellIsTheOfflineMapsOrSaysStored) {
  MapService s(o);
  submitAll(s, scans, 0, forward);
  const auto w1 = s.windowStats();
  ASSERT_TRUE(w1);
  EXPECT_GT(w1->left, 100u) << "blocks behind the robot left memory";
  EXPECT_GT(w1->blocks_out, 0u);
  const Tally t1 = compareFirst(s, forward);
  EXPECT_EQ(t1.wrong, 0u);
  EXPECT_GT(t1.stored, 1000u);
  EXPECT_GT(t1.same, 1000u);
  // The way back: the blocks it reaches come back and are updated with their real values.
  submitAll(s, scans, forward, scans.size());
  const auto w2 = s.windowStats();
  EXPECT_GT(w2->came_back, 100u);
  const Tally t2 = compareFirst(s, scans.size());
  EXPECT_EQ(t2.wrong, 0u) << t2.same << " same, " << t2.stored << " stored";
  EXPECT_GT(t2.stored, 1000u) << "now the far end is stored";
  const std::size_t in_memory = s.mapStore().read([](const map::OccupancyMap& m, std::uint64_t) {
    return static_cast<const map::GridMap&>(m).blockCount();
  });
  EXPECT_LT(in_memory, static_cast<const map::GridMap&>(*offline(scans, o.map)).blockCount() * 3 / 4);
}

TEST_F(ServiceWindow, BoxAndRayQueriesSayWhatIsStoredAndTheStatisticsCountIt) {
  MapService s(o);
  submitAll(s, scans, 0, forward);
  const auto w = s.windowStats();
  ASSERT_GT(w->blocks_out, 0u);
  // A box over the whole map: every stored block is named, and the cells listed are exactly the offline
  // map's occupied cells that are still in memory.
  const auto expected = offline({scans.begin(), scans.begin() + static_cast<std::ptrdiff_t>(forward)}, o.map);
  const float threshold = map::OccupancyParams::logOdds(expected->params().occupied_threshold);
  std::vector<geometry::Vec3f> occupied;
  expected->forEachCell([&](const geometry::VoxelKey& k, float v) {
    if (v >= threshold) occupied.push_back(expected->converter().toCoord(k));
  });
  const auto states = std::get<PointsAnswer>(s.answer(PointsQuery{occupied}).result).states;
  const auto in_memory = static_cast<std::size_t>(
      std::count_if(states.begin(), states.end(), [](CellState c) { return c != CellState::kNotInMemory; }));
  ASSERT_LT(in_memory, occupied.size());
  BoxQuery box;
  box.min = {-1000, -1000, -100};
  box.max = {1000, 1000, 100};
  box.limit = 1'000'000;
  const Answer a = s.answer(box);
  ASSERT_EQ(a.status, Status::kOk) << a.message;
  const auto& b = std::get<BoxAnswer>(a.result);
  EXPECT_EQ(b.blocks_not_in_memory, w->blocks_out);
  EXPECT_EQ(b.cells.size(), in_memory);
  EXPECT_NE(a.message.find("stored out of memory"), std::string::npos) << a.message;
  // A box around the robot holds no stored block.
  const geometry::Vec3f here = scans[forward - 1].origin();
  box.min = here - geometry::Vec3f(5, 5, 5);
  box.max = here + geometry::Vec3f(5, 5, 5);
  EXPECT_EQ(std::get<BoxAnswer>(s.answer(box).result).blocks_not_in_memory, 0u);
  // A ray from the robot back toward the start, unknown cells ignored: it stops where the stored blocks
  // begin instead of passing them as unknown. Within the radius, nothing is stored.
  RayQuery back;
  back.origin = here;
  back.direction = (scans[0].origin() - here).normalized();
  back.max_range = (scans[0].origin() - here).norm();
  back.ignore_unknown = true;
  const Answer ra = s.answer(back);
  ASSERT_EQ(ra.status, Status::kOk) << ra.message;
  const auto& r = std::get<RayAnswer>(ra.result);
  EXPECT_FALSE(r.hit) << ra.message;
  EXPECT_TRUE(r.reached_not_in_memory) << ra.message;
  RayQuery ahead = back;
  ahead.direction = -back.direction;
  ahead.max_range = static_cast<float>(o.window.radius_m / 2);
  EXPECT_FALSE(std::get<RayAnswer>(s.answer(ahead).result).reached_not_in_memory);
  // The statistics carry the window's counters.
  const ServiceStatistics st = s.statistics();
  ASSERT_TRUE(st.window);
  EXPECT_EQ(st.window->blocks_out, w->blocks_out);
  EXPECT_EQ(st.window->left, w->left);
  EXPECT_NE(st.summaryLine().find("blocks out of memory"), std::string::npos);
}

/// How many of `points` lie in blocks out of memory (read from the map, not through a query, which would
/// load them).
std::size_t storedAmong(MapService& s, const std::vector<geometry::Vec3f>& points) {
  return s.mapStore().read([&](const map::OccupancyMap& m, std::uint64_t) {
    const auto& grid = static_cast<const map::GridMap&>(m);
    std::size_t n = 0;
    for (const auto& p : points) {
      geometry::VoxelKey k;
      if (m.converter().toKey(p, k) && !grid.inMemory(k)) ++n;
    }
    return n;
  });
}

/// Submits scans [from, to) of robot r0 with map time t0 + i * 100 ms.
void submitTimed(MapService& s, const std::vector<io::Scan>& scans, std::size_t from, std::size_t to,
                 std::int64_t t0) {
  Outcomes out;
  for (std::size_t i = from; i < to; ++i) {
    server::ScanJob j = jobOf(scans[i], "r0", i);
    j.received_ns = t0 + static_cast<std::int64_t>(i) * 100'000'000;
    EXPECT_TRUE(s.submit(std::move(j), out.callback()).accepted);
  }
  ASSERT_TRUE(out.waitFor(to - from));
  EXPECT_EQ(out.count(ScanOutcome::kInMap), to - from) << out.lastWhy();
}

TEST_F(ServiceWindow, WithQueryLoadsAQueryBringsItsStoredBlocksBackForTheConfiguredTime) {
  const std::int64_t t0 = 1'700'000'000'000'000'000;
  ServiceOptions plain = o;
  plain.window.radius_m = 0.0;  // the same map, all of it in memory
  plain.data_dir = (tmp.path / "plain-data").string();
  o.window.query_load_s = 30.0;
  MapService s(o), all(plain);
  submitTimed(s, scans, 0, forward, t0);
  submitTimed(all, scans, 0, forward, t0);
  const std::uint64_t out_before = s.windowStats()->blocks_out;
  ASSERT_GT(out_before, 0u);
  // A ray back toward the start crosses stored blocks: they load, and it answers as the whole map does.
  const geometry::Vec3f here = scans[forward - 1].origin();
  RayQuery back;
  back.origin = here;
  back.direction = (scans[0].origin() - here).normalized();
  back.max_range = (scans[0].origin() - here).norm();
  back.ignore_unknown = true;
  const Answer ra = s.answer(back), rb = all.answer(back);
  ASSERT_EQ(ra.status, Status::kOk) << ra.message;
  const auto& r = std::get<RayAnswer>(ra.result);
  EXPECT_FALSE(r.reached_not_in_memory) << ra.message;
  EXPECT_EQ(r.hit, std::get<RayAnswer>(rb.result).hit) << ra.message << " / " << rb.message;
  EXPECT_EQ(r.hit_point, std::get<RayAnswer>(rb.result).hit_point);
  const std::uint64_t after_ray = s.windowStats()->loaded_for_queries;
  EXPECT_GT(after_ray, 0u);
  EXPECT_LT(s.windowStats()->blocks_out, out_before);
  // Every cell of the offline map answers its value: none says "not in memory" any more.
  const Tally t = compareFirst(s, forward);
  EXPECT_EQ(t.wrong, 0u);
  EXPECT_EQ(t.stored, 0u);
  EXPECT_GT(t.same, 1000u);
  EXPECT_EQ(s.windowStats()->blocks_out, 0u) << "every stored block holds a known cell";
  EXPECT_GT(s.windowStats()->loaded_for_queries, after_ray);
  // A box over everything then equals the whole map's.
  BoxQuery box;
  box.min = {-1000, -1000, -100};
  box.max = {1000, 1000, 100};
  box.limit = 1'000'000;
  const auto ba = std::get<BoxAnswer>(s.answer(box).result), bb = std::get<BoxAnswer>(all.answer(box).result);
  EXPECT_EQ(ba.blocks_not_in_memory, 0u);
  EXPECT_EQ(ba.cells.size(), bb.cells.size());
  // The next scans (map time within the 30 s) keep what the queries loaded, far as it is from the robot:
  // the first scan's cells beyond the radius (plus half a block's diagonal) still answer.
  std::vector<geometry::Vec3f> far_away;
  for (const auto& p : scans[0].worldPoints())
    if ((p - here).norm() > static_cast<float>(o.window.radius_m) + 3.0f) far_away.push_back(p);
  ASSERT_GT(far_away.size(), 100u);
  submitTimed(s, scans, forward, forward + 2, t0);
  EXPECT_EQ(storedAmong(s, far_away), 0u);
  // A scan 31 s of map time later: their time is over and they leave again.
  Outcomes out;
  server::ScanJob late = jobOf(scans[forward - 1], "r0", 1000);
  late.received_ns = t0 + 31'000'000'000 + static_cast<std::int64_t>(forward) * 100'000'000;
  ASSERT_TRUE(s.submit(std::move(late), out.callback()).accepted);
  ASSERT_TRUE(out.waitFor(1));
  EXPECT_EQ(storedAmong(s, far_away), far_away.size());
}

TEST_F(ServiceWindow, WithoutQueryLoadsAQueryLoadsNothing) {
  MapService s(o);
  submitAll(s, scans, 0, forward);
  const auto before = *s.windowStats();
  ASSERT_GT(before.blocks_out, 0u);
  EXPECT_GT(compareFirst(s, forward).stored, 1000u);
  EXPECT_EQ(s.windowStats()->blocks_out, before.blocks_out);
  EXPECT_EQ(s.windowStats()->loaded_for_queries, 0u);
}

/// Blocks around a robot that sent one scan and then nothing: forgotten after the timeout, kept without it.
std::size_t storedAroundAParkedRobot(ServiceOptions o, const std::vector<io::Scan>& scans, std::size_t n,
                                     std::uint64_t* forgotten) {
  MapService s(o);
  const std::int64_t t0 = 1'700'000'000'000'000'000;
  Outcomes out;
  server::ScanJob parked = jobOf(scans[0], "parked", 0);
  parked.received_ns = t0;
  EXPECT_TRUE(s.submit(std::move(parked), out.callback()).accepted);
  for (std::size_t i = 1; i < n; ++i) {
    server::ScanJob j = jobOf(scans[i], "driver", i);
    j.received_ns = t0 + static_cast<std::int64_t>(i) * 10'000'000'000;  // a scan every 10 s of map time
    EXPECT_TRUE(s.submit(std::move(j), out.callback()).accepted);
  }
  EXPECT_TRUE(out.waitFor(n));
  EXPECT_EQ(out.count(ScanOutcome::kInMap), n) << out.lastWhy();
  *forgotten = s.windowStats()->robots_forgotten;
  // The cells the parked robot's scan saw within 5 m of it.
  std::vector<geometry::Vec3f> near;
  for (const auto& p : scans[0].worldPoints())
    if ((p - scans[0].origin()).norm() < 5.0f) near.push_back(p);
  EXPECT_GT(near.size(), 100u);
  const auto states = std::get<PointsAnswer>(s.answer(PointsQuery{near}).result).states;
  return static_cast<std::size_t>(std::count(states.begin(), states.end(), CellState::kNotInMemory));
}

TEST_F(ServiceWindow, ARobotThatFallsSilentIsForgottenAfterTheTimeout) {
  o.window.robot_timeout_s = 30.0;
  std::uint64_t forgotten = 0;
  EXPECT_GT(storedAroundAParkedRobot(o, scans, forward, &forgotten), 100u) << "its neighbourhood left memory";
  EXPECT_EQ(forgotten, 1u);
  o.window.robot_timeout_s = 0.0;  // never: the parked robot keeps its neighbourhood in memory
  TempDir other;
  o.data_dir = (other.path / "data").string();
  EXPECT_EQ(storedAroundAParkedRobot(o, scans, forward, &forgotten), 0u);
  EXPECT_EQ(forgotten, 0u);
}

/// What the service logs (warnings and up) while `run` runs.
template <class F>
std::string logOf(F run) {
  std::ostringstream out;
  auto sink = std::make_shared<spdlog::sinks::ostream_sink_mt>(out);
  auto logger = spdlog::default_logger();
  logger->sinks().push_back(sink);
  run();
  logger->sinks().pop_back();
  return out.str();
}

TEST_F(ServiceWindow, ARadiusBelowTheSensorsRangeIsReportedOnceItMakesBlocksComeBack) {
  // 20 m against the simulator's scans reaching farther: the far blocks of a scan leave and come back.
  const std::string warned = logOf([&] {
    MapService s(o);
    submitAll(s, scans, 0, scans.size());
  });
  EXPECT_NE(warned.find("make the radius at least the sensor's range"), std::string::npos) << warned;
  // A cap alone also brings blocks back, but says nothing about a radius.
  o.window.radius_m = 0.0;
  o.window.max_map_mb = 0.5;
  TempDir other;
  o.data_dir = (other.path / "data").string();
  std::uint64_t came_back = 0;
  const std::string quiet = logOf([&] {
    MapService s(o);
    submitAll(s, scans, 0, scans.size());
    came_back = s.windowStats()->came_back;
  });
  EXPECT_GT(came_back, 0u);
  EXPECT_EQ(quiet.find("--window-radius"), std::string::npos) << quiet;
}

TEST_F(ServiceWindow, ARestartFromSnapshotAndJournalKeepsWhatWasStored) {
  o.durability.snapshot_on_exit = false;  // what a crash leaves
  {
    MapService a(o);
    submitAll(a, scans, 0, 4);
    ASSERT_EQ(a.execute(SnapshotCommand{}).status, Status::kOk);  // some blocks stored by now
    submitAll(a, scans, 4, forward);
  }
  MapService b(o);
  ASSERT_TRUE(b.recovery());
  EXPECT_EQ(b.recovery()->records_replayed, forward - 4);
  const Tally t1 = compareFirst(b, forward);
  EXPECT_EQ(t1.wrong, 0u);
  EXPECT_GT(t1.stored, 1000u);
  submitAll(b, scans, forward, scans.size());
  const Tally t2 = compareFirst(b, scans.size());
  EXPECT_EQ(t2.wrong, 0u) << t2.same << " same, " << t2.stored << " stored";
  EXPECT_GT(t2.same, 1000u);
}

TEST_F(ServiceWindow, DroppedBlocksAreForgottenAndACapBoundsMemory) {
  o.window.radius_m = 0.0;
  o.window.max_map_mb = 1.0;
  o.window.store = false;
  MapService s(o);
  submitAll(s, scans, 0, forward);
  const auto w = s.windowStats();
  EXPECT_GT(w->dropped, 0u);
  EXPECT_EQ(w->blocks_out, 0u) << "dropped blocks are gone, not stored";
  const std::size_t bytes =
      s.mapStore().read([](const map::OccupancyMap& m, std::uint64_t) { return m.memoryBytes(); });
  // The cap, plus what the last scan wrote (never evicted).
  EXPECT_LT(bytes, 2'000'000u);
  EXPECT_FALSE(fs::exists(fs::path(o.data_dir) / "blocks")) << "nothing stored";
  const Tally t = compareFirst(s, forward);
  EXPECT_EQ(t.stored, 0u);
  EXPECT_GT(t.wrong, 0u) << "forgotten cells answer unknown (what drop means)";
}

TEST_F(ServiceWindow, ADamagedStoredBlockRefusesTheScanThatReachesIt) {
  MapService s(o);
  submitAll(s, scans, 0, forward);
  const fs::path blocks = fs::path(o.data_dir) / "blocks";
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(blocks)) files.push_back(e.path());
  ASSERT_GT(files.size(), 10u);
  // Damage every stored block: the way back reaches them, and each scan that does is refused, acknowledged
  // with the file named; the map keeps what it had.
  for (const auto& f : files) std::ofstream(f, std::ios::trunc) << "not a block";
  const std::size_t known_before =
      s.mapStore().read([](const map::OccupancyMap& m, std::uint64_t) { return m.knownCells(); });
  Outcomes out;
  ASSERT_TRUE(s.submit(jobOf(scans[forward + 5], "r0", forward + 5), out.callback()).accepted);
  ASSERT_TRUE(out.waitFor(1));
  EXPECT_EQ(out.count(ScanOutcome::kRejected), 1u);
  EXPECT_NE(out.lastWhy().find("cannot be read"), std::string::npos) << out.lastWhy();
  EXPECT_NE(out.lastWhy().find(".dmb"), std::string::npos) << out.lastWhy();
  EXPECT_EQ(s.mapStore().read([](const map::OccupancyMap& m, std::uint64_t) { return m.knownCells(); }),
            known_before);
}

TEST_F(ServiceWindow, AStoreThatCannotWriteKeepsTheBlocksInMemory) {
  MapService s(o);
  const fs::path blocks = fs::path(o.data_dir) / "blocks";
  fs::remove_all(blocks);
  std::ofstream(blocks) << "a file where the folder was";
  submitAll(s, scans, 0, forward);
  EXPECT_EQ(s.windowStats()->left, 0u);
  EXPECT_GT(s.windowStats()->store_failures, 0u);
  const Tally t = compareFirst(s, forward);
  EXPECT_EQ(t.wrong, 0u);
  EXPECT_EQ(t.stored, 0u) << "every cell is still in memory";
}

TEST_F(ServiceWindow, WithoutAJournalABlocksFileGoesWhenTheBlockComesBack) {
  o.durability.journal = false;
  MapService s(o);
  submitAll(s, scans, 0, scans.size());
  const auto w = s.windowStats();
  EXPECT_GT(w->came_back, 100u);
  std::size_t files = 0;
  for (const auto& e : fs::directory_iterator(fs::path(o.data_dir) / "blocks"))
    files += e.path().extension() == ".dmb";
  EXPECT_EQ(files, w->blocks_out) << "one file per block out of memory, none for those that came back";
  const Tally t = compareFirst(s, scans.size());
  EXPECT_EQ(t.wrong, 0u);
}

}  // namespace
}  // namespace densemap::test
