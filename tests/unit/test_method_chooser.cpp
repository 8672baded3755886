// update/method_chooser.h and the engine's default method `fastest`: cheap methods tried first,
// the measured fastest chosen, losers re-tried ever less often, a change of data followed; and the map it
// builds is the baseline's.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <vector>

#include "densemap/io/lidar_simulator.h"
#include "densemap/map/grid_map.h"
#include "densemap/map/map_factory.h"
#include "densemap/update/method_chooser.h"
#include "densemap/update/update_engine.h"
#include "test_simulator.h"

namespace densemap::update {
namespace {

/// Runs `scans` scans whose cost per point (us) each method has in `cost`; returns the scans per method.
std::map<UpdateMethod, int> simulate(MethodChooser& c, const std::map<UpdateMethod, double>& cost,
                                     int scans) {
  std::map<UpdateMethod, int> used;
  for (int i = 0; i < scans; ++i) {
    const UpdateMethod m = c.next();
    ++used[m];
    c.record(m, cost.at(m) * 100.0 / 1000.0, 100);  // 100 points
  }
  return used;
}

TEST(MethodChooser, TriesTheCheapMethodsFirstAndTheSuperRayOnesOnlyLater) {
  MethodChooser c;
  const std::map<UpdateMethod, double> cost = {{UpdateMethod::kBaseline, 1.0},
                                               {UpdateMethod::kCullingRegion, 0.9},
                                               {UpdateMethod::kSuperRays, 2.0},
                                               {UpdateMethod::kSuperRaysCulling, 1.8}};
  const auto first = simulate(c, cost, 10);  // a ten-scan benchmark
  EXPECT_EQ(first.count(UpdateMethod::kSuperRays), 0u);
  EXPECT_EQ(first.count(UpdateMethod::kSuperRaysCulling), 0u);
  // Two samples of each cheap method (the first scan of a run is a cold one), then the faster.
  EXPECT_EQ(first.at(UpdateMethod::kBaseline), 2);
  EXPECT_EQ(first.at(UpdateMethod::kCullingRegion), 8);
  EXPECT_EQ(c.best(), UpdateMethod::kCullingRegion);
}

TEST(MethodChooser, LosersAreRetriedEverLessOften) {
  MethodChooser c;
  const std::map<UpdateMethod, double> cost = {{UpdateMethod::kBaseline, 1.0},
                                               {UpdateMethod::kCullingRegion, 1.3},
                                               {UpdateMethod::kSuperRays, 2.0},
                                               {UpdateMethod::kSuperRaysCulling, 1.8}};
  const auto used = simulate(c, cost, 5000);
  EXPECT_EQ(c.best(), UpdateMethod::kBaseline);
  // Intervals 20, 40, ... 640: each loser runs about a dozen times in 5,000 scans, so the time lost to
  // trying them is under 1% here.
  for (UpdateMethod m :
       {UpdateMethod::kCullingRegion, UpdateMethod::kSuperRays, UpdateMethod::kSuperRaysCulling}) {
    EXPECT_GE(used.at(m), 3) << toString(m);
    EXPECT_LE(used.at(m), 16) << toString(m);
  }
  double spent = 0, best = 5000 * 1.0;
  for (const auto& [m, n] : used) spent += n * cost.at(m);
  EXPECT_LT(spent / best, 1.01);
}

TEST(MethodChooser, TriesCostAboutTheBudgetInShortAndLongRuns) {
  const std::map<UpdateMethod, double> cost = {{UpdateMethod::kBaseline, 1.0},
                                               {UpdateMethod::kCullingRegion, 1.3},
                                               {UpdateMethod::kSuperRays, 2.0},
                                               {UpdateMethod::kSuperRaysCulling, 1.8}};
  for (const int scans : {30, 60, 200, 1000}) {
    MethodChooser c;
    const auto used = simulate(c, cost, scans);
    double spent = 0;
    for (const auto& [m, n] : used) spent += n * cost.at(m);
    // Beyond the fastest's time: the budget (2%), the two cold-start tries of culling (0.3 scans each) and
    // at most one try that cost more than expected (an untried method, assumed 0.5 scans over, took 0.8).
    const double allowed = 0.02 * scans + 2 * 0.3 + 0.3;
    EXPECT_LE(spent - scans * 1.0, allowed + 1e-9) << scans << " scans: " << c.summary();
  }
  // Without a budget every due loser is tried: a 60-scan run pays for two tries of each super-ray method.
  MethodChooserOptions unlimited;
  unlimited.probe_budget = 1e9;
  MethodChooser c(unlimited);
  const auto used = simulate(c, cost, 60);
  EXPECT_EQ(used.at(UpdateMethod::kSuperRays), 2);
  EXPECT_EQ(used.at(UpdateMethod::kSuperRaysCulling), 2);
}

TEST(MethodChooser, FollowsTheDataWhenAnotherMethodBecomesFaster) {
  MethodChooser c;
  std::map<UpdateMethod, double> cost = {{UpdateMethod::kBaseline, 1.0},
                                         {UpdateMethod::kCullingRegion, 1.2},
                                         {UpdateMethod::kSuperRays, 1.5},
                                         {UpdateMethod::kSuperRaysCulling, 1.4}};
  simulate(c, cost, 300);
  ASSERT_EQ(c.best(), UpdateMethod::kBaseline);
  cost[UpdateMethod::kSuperRaysCulling] = 0.4;  // denser scans: super rays now carry many points
  const auto after = simulate(c, cost, 1500);
  EXPECT_EQ(c.best(), UpdateMethod::kSuperRaysCulling);
  EXPECT_GT(after.at(UpdateMethod::kSuperRaysCulling), 1000);
  EXPECT_NE(c.summary().find("superrays+culling"), std::string::npos);
}

TEST(MethodChooser, AColdFirstScanDoesNotCondemnAMethod) {
  MethodChooser c;
  // Baseline's first scan is slow (cold caches); afterwards it is the fastest.
  EXPECT_EQ(c.next(), UpdateMethod::kBaseline);
  c.record(UpdateMethod::kBaseline, 5.0, 100);
  EXPECT_EQ(c.next(), UpdateMethod::kCullingRegion);
  c.record(UpdateMethod::kCullingRegion, 0.12, 100);
  // Its second try comes at once, not at the first re-try 20 scans later: from the fourth scan on the
  // baseline runs.
  EXPECT_EQ(c.next(), UpdateMethod::kBaseline);
  c.record(UpdateMethod::kBaseline, 0.10, 100);
  EXPECT_EQ(c.next(), UpdateMethod::kCullingRegion);
  c.record(UpdateMethod::kCullingRegion, 0.12, 100);
  EXPECT_EQ(c.next(), UpdateMethod::kBaseline);
  c.record(UpdateMethod::kBaseline, 0.10, 100);
  std::map<UpdateMethod, double> cost = {{UpdateMethod::kBaseline, 1.0},
                                         {UpdateMethod::kCullingRegion, 1.2},
                                         {UpdateMethod::kSuperRays, 3.0},
                                         {UpdateMethod::kSuperRaysCulling, 3.0}};
  simulate(c, cost, 200);
  EXPECT_EQ(c.best(), UpdateMethod::kBaseline);
}

TEST(MethodChooser, TheFastestMethodBuildsTheBaselinesMapAndSaysWhatItRan) {
  io::LidarSimulator sim(test::smallSimulator(12));
  for (const double res : {0.2, 0.4}) {
    auto reference = map::makeMap({"grid", res, {}});
    auto chosen = map::makeMap({"grid", res, {}});
    UpdateOptions base;
    base.method = UpdateMethod::kBaseline;
    UpdateOptions fast;  // the default
    ASSERT_EQ(fast.method, UpdateMethod::kFastest);
    fast.chooser.min_saving_to_measure = 0.0;  // consult the chooser for every scan
    fast.chooser.probe_after = 2;              // let all four run within a short test
    fast.chooser.probe_interval = 2;
    // and pay for them whatever the timings (a budget tied to measured times made this test depend on
    // the machine's load: under load superrays was never tried in 12 scans)
    fast.chooser.probe_budget = 1e6;
    fast.chooser.untried_extra = 0.0;
    UpdateEngine a(base), b(fast);
    std::map<UpdateMethod, int> ran;
    for (std::size_t i = 0; i < 12; ++i) {
      const io::Scan s = sim.read(i);
      const auto world = s.worldPoints();
      const auto origin = s.origin();
      ASSERT_TRUE(a.insert(*reference, world, origin));
      const auto st = b.insert(*chosen, world, origin);
      ASSERT_TRUE(st);
      ASSERT_NE(st->method, UpdateMethod::kFastest);
      ++ran[st->method];
    }
    EXPECT_EQ(ran.size(), 4u) << "every method ran at least once";
    std::string why;
    EXPECT_TRUE(static_cast<const map::GridMap&>(*chosen).identical(
        static_cast<const map::GridMap&>(*reference), &why))
        << why;
    std::uint64_t counted = 0;
    for (UpdateMethod m : kAllMethods) counted += b.chooser().scans(m);
    EXPECT_EQ(counted, 12u);
  }
}

/// A scan of `rays` directions from the origin to a wall `range` metres away along x, each direction hit by
/// `per_cell` points inside one cell of size `res` (so `per_cell` points per endpoint cell).
std::vector<geometry::Vec3f> wallScan(int rays, int per_cell, double range, double res) {
  std::vector<geometry::Vec3f> pts;
  const int side = static_cast<int>(std::sqrt(static_cast<double>(rays)));
  for (int i = 0; i < side; ++i)
    for (int j = 0; j < side; ++j)
      for (int p = 0; p < per_cell; ++p) {
        // Cell centres 3 cells apart on the wall, the points spread within +-0.3 of a cell around them.
        const double y = (i - side / 2) * 3.0 * res + res * (0.5 + 0.3 * std::sin(p * 1.7));
        const double z = (j - side / 2) * 3.0 * res + res * (0.5 + 0.3 * std::cos(p * 2.3));
        pts.emplace_back(static_cast<float>(range + 0.5 * res), static_cast<float>(y), static_cast<float>(z));
      }
  return pts;
}

TEST(MethodChooser, TheDefaultRunsTheBaselineWhereSuperRaysCannotSaveAndMeasuresWhereTheyCould) {
  const double res = 0.1;
  const geometry::Vec3f origin(0.05f, 0.05f, 0.05f);
  // Walks of 210-270 cells either way; one point per endpoint cell saves nothing, 20 save 95% of a walk.
  const std::vector<geometry::Vec3f> sparse = wallScan(400, 1, 20.0, res),
                                     dense = wallScan(400, 20, 20.0, res);
  for (const bool is_dense : {false, true}) {
    auto m = map::makeMap({"grid", res, {}});
    UpdateEngine engine;  // the default options
    ASSERT_EQ(engine.options().method, UpdateMethod::kFastest);
    std::map<UpdateMethod, int> ran;
    int consulted = 0;
    for (int scan = 0; scan < 8; ++scan) {
      const auto st = engine.insert(*m, is_dense ? dense : sparse, origin);
      ASSERT_TRUE(st);
      ++ran[st->method];
      consulted += st->chooser_consulted ? 1 : 0;
      // 200 cells along x plus the L1 offsets across the wall (up to 30 cells each way in y and z).
      EXPECT_GT(st->walk_cells_per_ray, 210.0);
      EXPECT_LT(st->walk_cells_per_ray, 270.0);
      EXPECT_EQ(st->end_cells, 400u);
      // The rule's input and its threshold.
      EXPECT_NEAR(st->super_ray_saving, st->walk_cells_per_ray * (is_dense ? 0.95 : 0.0), 1e-9);
      EXPECT_EQ(st->super_ray_saving >= engine.options().chooser.min_saving_to_measure, is_dense);
    }
    if (is_dense) {
      // The first scan has nothing to go on (baseline); from the second the chooser decides and tries the
      // cheap methods first (baseline and culling, twice each).
      EXPECT_EQ(consulted, 7);
      EXPECT_GE(ran[UpdateMethod::kCullingRegion], 1);
      EXPECT_EQ(engine.chooser().scans(UpdateMethod::kBaseline) +
                    engine.chooser().scans(UpdateMethod::kCullingRegion) +
                    engine.chooser().scans(UpdateMethod::kSuperRays) +
                    engine.chooser().scans(UpdateMethod::kSuperRaysCulling),
                7u);
    } else {
      EXPECT_EQ(consulted, 0);
      EXPECT_EQ(ran[UpdateMethod::kBaseline], 8) << "no tries where super rays cannot save";
      EXPECT_EQ(engine.chooser().scans(UpdateMethod::kBaseline), 0u) << "the chooser was not consulted";
    }
  }
}

}  // namespace
}  // namespace densemap::update
