// MapService without any transport: scans in, every query kind and command answered, statistics, stop.
// The same behaviour the DDS service tests assert end to end, here on the plain C++ types.
#include <condition_variable>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <thread>

#include <gtest/gtest.h>

#include "densemap/io/lidar_simulator.h"
#include "densemap/map/grid_map.h"
#include "densemap/map/octree_map.h"
#include "densemap/server/map_service.h"
#include "densemap/sources/open_source.h"
#include "densemap/update/update_engine.h"
#include "map_service_helpers.h"
#include "test_data.h"
#include "test_simulator.h"

namespace densemap::test {
namespace {

using namespace server;
using namespace std::chrono_literals;

ServiceOptions options(const std::string& tag) {
  ServiceOptions o;
  o.map_dir = (std::filesystem::temp_directory_path() / ("densemap-unit-" + tag)).string();
  std::filesystem::remove_all(o.map_dir);
  o.data_dir = o.map_dir + "-data";
  std::filesystem::remove_all(o.data_dir);
  o.update_nice = 0;
  return o;
}

/// The occupancy layer's probabilities at the points, asked in chunks under the per-query limit.
std::vector<float> probabilitiesAt(MapService& service, const std::vector<Vec3f>& points) {
  std::vector<float> out;
  constexpr std::size_t kChunk = 200'000;
  for (std::size_t begin = 0; begin < points.size(); begin += kChunk) {
    const std::size_t end = std::min(points.size(), begin + kChunk);
    const Answer a = service.answer(PointsQuery{{points.begin() + static_cast<std::ptrdiff_t>(begin),
                                                 points.begin() + static_cast<std::ptrdiff_t>(end)},
                                                Layer::kOccupancy});
    EXPECT_EQ(a.status, Status::kOk) << a.message;
    if (a.status != Status::kOk) return {};
    const auto& p = std::get<PointsAnswer>(a.result);
    out.insert(out.end(), p.probabilities.begin(), p.probabilities.end());
  }
  return out;
}

void submitAll(MapService& s, const std::vector<io::Scan>& scans, Outcomes& out,
               const std::string& robot = "r0", std::uint64_t first = 0) {
  for (std::size_t i = 0; i < scans.size(); ++i)
    EXPECT_TRUE(s.submit(jobOf(scans[i], robot, first + i), out.callback()).accepted);
}

TEST(MapService, ScansMapExactlyAndEveryOutcomeIsHeard) {
  const auto scans = simScans(5);
  MapService service(options("exact"));
  Outcomes out;
  submitAll(service, scans, out);
  ASSERT_TRUE(out.waitFor(scans.size()));
  EXPECT_EQ(out.count(ScanOutcome::kInMap), scans.size());
  expectAnswers(service, *offline(scans, service.options().map));
  const ServiceStatistics st = service.statistics();
  ASSERT_EQ(st.robots.size(), 1u);
  EXPECT_EQ(st.robots[0].second.processed, scans.size());
  EXPECT_EQ(st.map_version, scans.size());
}

TEST(MapService, Kitti00ScansMapExactly) {
  DENSEMAP_REQUIRE_DATA("kitti00");
  const auto src = sources::openSource(dataDir() + "/kitti00");
  std::vector<io::Scan> scans;
  for (std::size_t i = 0; i < 5; ++i) scans.push_back(src->read(i));
  MapService service(options("kitti"));
  Outcomes out;
  submitAll(service, scans, out);
  ASSERT_TRUE(out.waitFor(scans.size()));
  expectAnswers(service, *offline(scans, service.options().map));
}

TEST(MapService, BadScansAreRejectedAtTheDoorAndCounted) {
  const auto scans = simScans(1);
  MapService service(options("bad"));
  Outcomes out;
  ScanJob nan = jobOf(scans[0], "r0", 0);
  nan.position[0] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(service.submit(std::move(nan), out.callback()).accepted);
  ScanJob far = jobOf(scans[0], "r0", 1);
  far.position[0] = 1e6;  // outside the key range at 0.2 m
  const SubmitResult r = service.submit(std::move(far), out.callback());
  EXPECT_FALSE(r.accepted);
  EXPECT_NE(r.why.find("key range"), std::string::npos) << r.why;
  ScanJob anonymous = jobOf(scans[0], "", 2);
  EXPECT_FALSE(service.submit(std::move(anonymous), out.callback()).accepted);
  service.refuse(jobOf(scans[0], "r0", 3), "points must be packed x y z", out.callback());
  ASSERT_TRUE(out.waitFor(4));
  EXPECT_EQ(out.count(ScanOutcome::kRejected), 4u);
  EXPECT_EQ(std::get<MapSummary>(service.answer(StatsQuery{}).result).known_cells, 0u);
}

TEST(MapService, EveryQueryKindIsAnswered) {
  const auto scans = simScans(3);
  MapService service(options("queries"));
  Outcomes out;
  submitAll(service, scans, out);
  ASSERT_TRUE(out.waitFor(scans.size()));
  const auto expected = offline(scans, service.options().map);
  // Box: every occupied cell inside, up to the limit.
  BoxQuery box{Vec3f(-50, -50, -5), Vec3f(50, 50, 10), 0, Layer::kOccupancy};
  const Answer all = service.answer(box);
  ASSERT_EQ(all.status, Status::kOk) << all.message;
  std::size_t occupied = 0;
  expected->forEachCell([&](const geometry::VoxelKey& k, float v) {
    const Vec3f c = expected->converter().toCoord(k);
    if (v >= expected->logOddsParams().occupied && (c.array() >= box.min.array()).all() &&
        (c.array() <= box.max.array()).all())
      ++occupied;
  });
  EXPECT_EQ(std::get<BoxAnswer>(all.result).cells.size(), occupied);
  box.limit = 10;
  const Answer limited = service.answer(box);
  const auto& few = std::get<BoxAnswer>(limited.result);
  EXPECT_EQ(few.cells.size(), 10u);
  EXPECT_TRUE(few.truncated);
  // Ray: from the first sensor origin towards an occupied cell it meets one (that cell or one before it).
  Vec3f target = Vec3f::Zero();
  expected->forEachCell([&](const geometry::VoxelKey& k, float v) {
    if (v >= expected->logOddsParams().occupied) target = expected->converter().toCoord(k);
  });
  const Vec3f from = scans[0].origin();
  const Answer ray =
      service.answer(RayQuery{from, target - from, (target - from).norm() + 1.0f, true, Layer::kOccupancy});
  ASSERT_EQ(ray.status, Status::kOk) << ray.message;
  const auto& hit = std::get<RayAnswer>(ray.result);
  EXPECT_TRUE(hit.hit) << ray.message;
  geometry::VoxelKey k;
  ASSERT_TRUE(expected->converter().toKey(hit.hit_point, k));
  EXPECT_GE(*expected->logOdds(k), expected->logOddsParams().occupied) << "the hit cell is occupied";
  // Points: unknown far away, NaN answered unknown.
  const Answer pts =
      service.answer(PointsQuery{{Vec3f(900, 900, 900), Vec3f::Constant(NAN)}, Layer::kOccupancy});
  ASSERT_EQ(pts.status, Status::kOk);
  EXPECT_EQ(std::get<PointsAnswer>(pts.result).states[0], CellState::kUnknown);
  EXPECT_EQ(std::get<PointsAnswer>(pts.result).states[1], CellState::kUnknown);
  // Refusals, each with a status and a message; the map is untouched.
  EXPECT_EQ(service.answer(BoxQuery{Vec3f(1, 1, 1), Vec3f(0, 2, 2), 0, Layer::kOccupancy}).status,
            Status::kInvalidArgument);
  EXPECT_EQ(service.answer(RayQuery{Vec3f::Zero(), Vec3f::Zero(), 10.0f, false, Layer::kOccupancy}).status,
            Status::kInvalidArgument);
  EXPECT_EQ(service.answer(PointsQuery{{}, Layer::kDense}).status, Status::kLayerUnavailable);
  EXPECT_EQ(service.statistics().queries_failed, 3u);
  expectAnswers(service, *expected);
}

TEST(MapService, ClearBoxAndResetGoThroughTheWriterAndChangeOnlyWhatTheyAsk) {
  const auto scans = simScans(3);
  auto o = options("clear");
  o.dense.method = "bgk";
  o.dense.max_range = 15.0;
  MapService service(o);
  Outcomes out;
  submitAll(service, scans, out);
  ASSERT_TRUE(out.waitFor(scans.size()));
  auto expected = offline(scans, o.map);
  const Vec3f lo(-12, -3, -1), hi(-8, 3, 3);
  geometry::VoxelKey klo, khi;
  expected->converter().toKey(lo, klo);
  expected->converter().toKey(hi, khi);
  const std::size_t erased = expected->eraseBox(klo, khi);
  ASSERT_GT(erased, 0u);
  const CommandResult c = service.execute(ClearBoxCommand{lo, hi}, "test");
  ASSERT_EQ(c.status, Status::kOk) << c.message;
  EXPECT_EQ(c.cells_changed, erased);
  expectAnswers(service, *expected);
  // The reset travels behind the dense stage's queued scans, so afterwards both layers are empty even
  // though the dense layer may still have been working on the scans above.
  const CommandResult r = service.execute(ResetCommand{}, "test");
  ASSERT_EQ(r.status, Status::kOk) << r.message;
  EXPECT_EQ(r.cells_changed, expected->knownCells());
  EXPECT_EQ(std::get<MapSummary>(service.answer(StatsQuery{}).result).known_cells, 0u);
  const Answer dense = service.answer(PointsQuery{{scans[0].worldPoints()[0]}, Layer::kDense});
  ASSERT_EQ(dense.status, Status::kOk);
  EXPECT_EQ(std::get<PointsAnswer>(dense.result).states[0], CellState::kUnknown)
      << "the dense layer was reset";
  // Scans after the reset map from nothing.
  Outcomes more;
  submitAll(service, {scans[2]}, more, "r0", 10);
  ASSERT_TRUE(more.waitFor(1));
  expectAnswers(service, *offline({scans[2]}, o.map));
  EXPECT_EQ(service.statistics().commands_done, 2u);
}

/// Saves the scans' map as .ot and .bt, loads each into a fresh service, and checks every cell's answer.
void expectSavesLoadBack(const std::vector<io::Scan>& scans, const std::string& tag) {
  for (const char* backend : {"grid", "octree"}) {
    auto o = options(tag + "-save-" + backend);
    o.map.backend = backend;
    std::unique_ptr<map::OccupancyMap> before;
    {
      MapService service(o);
      Outcomes out;
      submitAll(service, scans, out);
      ASSERT_TRUE(out.waitFor(scans.size()));
      const CommandResult ot = service.execute(SaveCommand{"run.ot"}, "test");
      ASSERT_EQ(ot.status, Status::kOk) << ot.message;
      ASSERT_TRUE(ot.map);
      EXPECT_EQ(ot.map->known_cells, offline(scans, o.map)->knownCells());
      ASSERT_EQ(service.execute(SaveCommand{"run.bt"}, "test").status, Status::kOk);
      before = offline(scans, o.map);
    }
    MapService fresh(o);
    const CommandResult loaded = fresh.execute(LoadCommand{"run.ot"}, "test");
    ASSERT_EQ(loaded.status, Status::kOk) << loaded.message;
    expectAnswers(fresh, *before);
    // .bt keeps each cell's state at the clamping values.
    ASSERT_EQ(fresh.execute(LoadCommand{"run.bt"}, "test").status, Status::kOk);
    const map::LogOdds lo(o.map.params);
    std::vector<Vec3f> points;
    std::vector<float> want;
    before->forEachCell([&](const geometry::VoxelKey& k, float v) {
      points.push_back(before->converter().toCoord(k));
      want.push_back(map::OccupancyParams::probability(v >= lo.occupied ? lo.max : lo.min));
    });
    const std::vector<float> got = probabilitiesAt(fresh, points);
    ASSERT_EQ(got.size(), want.size());
    std::size_t wrong = 0;
    for (std::size_t i = 0; i < want.size(); ++i) wrong += got[i] != want[i];
    EXPECT_EQ(wrong, 0u) << backend << ": .bt cells at their state's clamping value";
    // Scans go on updating a loaded map.
    Outcomes out;
    submitAll(fresh, {scans[0]}, out, "r1");
    ASSERT_TRUE(out.waitFor(1));
    EXPECT_EQ(out.count(ScanOutcome::kInMap), 1u);
  }
}

TEST(MapService, SavedMapsLoadBackAndAnswerIdentically) { expectSavesLoadBack(simScans(3), "sim"); }

TEST(MapService, Kitti00SavedMapsLoadBackAndAnswerIdentically) {
  DENSEMAP_REQUIRE_DATA("kitti00");
  const auto src = sources::openSource(dataDir() + "/kitti00");
  std::vector<io::Scan> scans;
  for (std::size_t i = 0; i < 3; ++i) scans.push_back(src->read(i));
  expectSavesLoadBack(scans, "kitti");
}

TEST(MapService, SavesAndLoadsStayInTheMapDirectory) {
  auto o = options("confined");
  MapService service(o);
  const std::filesystem::path outside = std::filesystem::temp_directory_path() / "densemap-unit-outside.bt";
  std::filesystem::remove(outside);
  for (const std::string& name :
       {outside.string(), std::string("../densemap-unit-outside.bt"), std::string(".hidden.bt"),
        std::string("map.txt"), std::string(""), std::string("a/b.ot")}) {
    const CommandResult r = service.execute(SaveCommand{name}, "test");
    EXPECT_EQ(r.status, Status::kInvalidArgument) << "'" << name << "': " << r.message;
    EXPECT_FALSE(r.message.empty());
  }
  EXPECT_FALSE(std::filesystem::exists(outside));
  // A symbolic link in the map directory that leads out is neither followed by a save nor a load.
  ASSERT_EQ(service.execute(SaveCommand{"first.bt"}, "test").status, Status::kOk);
  const std::string secret = (std::filesystem::temp_directory_path() / "densemap-unit-secret").string();
  { std::ofstream(secret) << "do not touch"; }
  std::filesystem::create_symlink(secret, std::filesystem::path(o.map_dir) / "link.bt");
  EXPECT_EQ(service.execute(LoadCommand{"link.bt"}, "test").status, Status::kInvalidArgument);
  ASSERT_EQ(service.execute(SaveCommand{"link.bt"}, "test").status, Status::kOk);
  std::ifstream in(secret);
  std::string text;
  std::getline(in, text);
  EXPECT_EQ(text, "do not touch") << "the save replaced the link, not what it pointed to";
  EXPECT_FALSE(std::filesystem::is_symlink(std::filesystem::path(o.map_dir) / "link.bt"));
  EXPECT_EQ(service.execute(LoadCommand{"missing.ot"}, "test").status, Status::kNotFound);
  // A corrupt file is refused and the map stays as it was.
  {
    std::ofstream(std::filesystem::path(o.map_dir) / "corrupt.ot")
        << "# Octomap OcTree file\nid OcTree\nsize 5\n";
  }
  const CommandResult bad = service.execute(LoadCommand{"corrupt.ot"}, "test");
  EXPECT_EQ(bad.status, Status::kInvalidArgument) << bad.message;
  std::filesystem::remove(secret);
}

TEST(MapService, StopDrainsOrDropsAndRefusesLateWork) {
  const auto scans = simScans(4);
  MapService service(options("stop"));
  Outcomes out;
  submitAll(service, scans, out);
  service.stop(false);  // whatever was still queued is dropped, counted
  ASSERT_TRUE(out.waitFor(scans.size()));
  EXPECT_EQ(out.count(ScanOutcome::kInMap) + out.count(ScanOutcome::kDropped), scans.size());
  const SubmitResult late = service.submit(jobOf(scans[0], "r0", 9), out.callback());
  EXPECT_FALSE(late.accepted);
  ASSERT_TRUE(out.waitFor(scans.size() + 1)) << "a scan refused after stop is still reported";
  EXPECT_EQ(service.execute(ResetCommand{}, "test").status, Status::kUnavailable);
  EXPECT_EQ(service.answer(StatsQuery{}).status, Status::kOk) << "queries are still answered";
}

}  // namespace
}  // namespace densemap::test
