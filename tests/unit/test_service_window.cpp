// The rolling window and the memory cap in the service (issue 22): blocks far from the robots or past the
// cap leave memory, come back when a scan reaches them, and the map stays the map of every scan: each cell
// answers exactly the offline map's value, or says it is stored out of memory. Also across a restart.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

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
