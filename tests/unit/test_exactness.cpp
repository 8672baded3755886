// Every update method gives its baseline's map cell for cell, bitwise, for both backends and semantics;
// for octree + batch the baseline is OctoMap's own insertPointCloud.
#include <memory>
#include <string>

#include <omp.h>

#include <gtest/gtest.h>
#include <octomap/octomap.h>

#include "densemap/io/lidar_simulator.h"
#include "densemap/map/grid_map.h"
#include "densemap/map/octree_map.h"
#include "densemap/sources/open_source.h"
#include "densemap/update/update_engine.h"
#include "test_data.h"
#include "test_simulator.h"

namespace densemap {
namespace {

using map::UpdateSemantics;
using update::UpdateMethod;

struct Case {
  std::string source;
  std::size_t first, last;  // inclusive
  double resolution;
  double max_range = -1.0;
};

std::unique_ptr<map::OccupancyMap> makeMap(const std::string& backend, double res) {
  if (backend == "grid") return std::make_unique<map::GridMap>(res);
  return std::make_unique<map::OctreeMap>(res);
}

bool sameMap(const map::OccupancyMap& a, const map::OccupancyMap& b, std::string* why) {
  if (a.backendName() == "grid")
    return static_cast<const map::GridMap&>(a).identical(static_cast<const map::GridMap&>(b), why);
  return map::identicalTrees(static_cast<const map::OctreeMap&>(a).tree(),
                             static_cast<const map::OctreeMap&>(b).tree(), why);
}

octomap::Pointcloud toOctomap(const std::vector<geometry::Vec3f>& pts) {
  octomap::Pointcloud pc;
  pc.reserve(pts.size());
  for (const auto& p : pts) pc.push_back(p.x(), p.y(), p.z());
  return pc;
}

void checkCase(const io::ScanSource& src, const Case& c) {
  std::vector<std::pair<std::vector<geometry::Vec3f>, geometry::Vec3f>> scans;
  for (std::size_t i = c.first; i <= c.last; ++i) {
    const io::Scan s = src.read(i);
    scans.emplace_back(s.worldPoints(), s.origin());
  }
  // OctoMap's reference map (octree + batch).
  auto reference = map::OctreeMap::makeTree(c.resolution, {});
  const int threads = omp_get_max_threads();
  for (const auto& [pts, o] : scans)
    reference->insertPointCloud(toOctomap(pts), octomap::point3d(o.x(), o.y(), o.z()), c.max_range, false,
                                false);
  // OctoMap's header code sets the OpenMP thread count to 1 (see densemap-bench); restore it.
  omp_set_num_threads(threads);

  for (const std::string backend : {"grid", "octree"}) {
    for (UpdateSemantics sem : {UpdateSemantics::kBatch, UpdateSemantics::kCounting}) {
      std::unique_ptr<map::OccupancyMap> baseline;
      for (UpdateMethod m : update::kAllMethods) {
        update::UpdateOptions opt;
        opt.method = m;
        opt.semantics = sem;
        opt.max_range = c.max_range;
        update::UpdateEngine engine(opt);
        auto mp = makeMap(backend, c.resolution);
        for (const auto& [pts, o] : scans) ASSERT_TRUE(engine.insert(*mp, pts, o).has_value());
        const std::string what = c.source + " res " + std::to_string(c.resolution) + " " + backend + " " +
                                 std::string(map::toString(sem)) + " " + std::string(update::toString(m));
        std::string why;
        if (!baseline) {
          baseline = std::move(mp);
          if (backend == "octree" && sem == UpdateSemantics::kBatch) {
            EXPECT_TRUE(map::identicalTrees(static_cast<map::OctreeMap&>(*baseline).tree(), *reference, &why))
                << what << " vs OctoMap insertPointCloud: " << why;
          }
          EXPECT_GT(baseline->knownCells(), 0u) << what;
          continue;
        }
        EXPECT_TRUE(sameMap(*baseline, *mp, &why)) << what << ": " << why;
      }
    }
  }
}

class ExactnessOnData : public ::testing::TestWithParam<double> {};

TEST_P(ExactnessOnData, Kitti00FirstScans) {
  DENSEMAP_REQUIRE_DATA("kitti00");
  auto src = sources::openSource(test::dataDir() + "/kitti00");
  checkCase(*src, {"kitti00", 0, 9, GetParam()});
}

TEST_P(ExactnessOnData, Hilti2023) {
  DENSEMAP_REQUIRE_DATA("hilti2023");
  auto src = sources::openSource(test::dataDir() + "/hilti2023");
  checkCase(*src, {"hilti2023", 0, src->size() - 1, GetParam()});
}

TEST_P(ExactnessOnData, La3dmStructured) {
  DENSEMAP_REQUIRE_DATA("la3dm/sim_structured");
  auto src = sources::openSource(test::dataDir() + "/la3dm/sim_structured");
  checkCase(*src, {"la3dm", 0, src->size() - 1, GetParam()});
}

TEST_P(ExactnessOnData, La3dmUnstructured) {
  DENSEMAP_REQUIRE_DATA("la3dm/sim_unstructured");
  auto src = sources::openSource(test::dataDir() + "/la3dm/sim_unstructured");
  checkCase(*src, {"la3dm-unstructured", 0, src->size() - 1, GetParam()});
}

INSTANTIATE_TEST_SUITE_P(Resolutions, ExactnessOnData, ::testing::Values(0.1, 0.2, 0.4, 0.8));

TEST(Exactness, SimulatorWithMaxRange) {
  io::LidarSimulator sim(test::smallSimulator(8, 32, 512, 1.0, 0.01));
  for (double res : {0.2, 0.4}) checkCase(sim, {"sim", 0, 7, res, 25.0});
}

TEST(Exactness, SimulatorDenseCoarse) {
  // Dense scans at a coarse resolution: many points per voxel, so super rays group a lot.
  io::LidarSimulator sim(test::smallSimulator(6, 64, 1024));
  checkCase(sim, {"sim-dense", 0, 5, 0.8});
}

TEST(Exactness, ResultsDoNotDependOnTheThreadCount) {
  io::LidarSimulator sim(test::smallSimulator(8));
  const int saved = omp_get_max_threads();
  for (const std::string backend : {"grid", "octree"})
    for (UpdateSemantics sem : {UpdateSemantics::kBatch, UpdateSemantics::kCounting})
      for (UpdateMethod m : update::kAllMethods) {
        std::unique_ptr<map::OccupancyMap> maps[2];
        for (int t = 0; t < 2; ++t) {
          omp_set_num_threads(t == 0 ? 1 : 3);
          update::UpdateEngine engine(update::UpdateOptions{.method = m, .semantics = sem});
          maps[t] = makeMap(backend, 0.3);
          for (std::size_t i = 0; i < sim.size(); ++i) {
            const io::Scan s = sim.read(i);
            ASSERT_TRUE(engine.insert(*maps[t], s.worldPoints(), s.origin()).has_value());
          }
        }
        std::string why;
        EXPECT_TRUE(sameMap(*maps[0], *maps[1], &why))
            << backend << " " << map::toString(sem) << " " << update::toString(m) << ": " << why;
      }
  omp_set_num_threads(saved);
}

}  // namespace
}  // namespace densemap
