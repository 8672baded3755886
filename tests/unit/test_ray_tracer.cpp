// traceRays under batch semantics uses walks specialised by step sign with an incrementally stepped
// Morton index (batch_marking_walk.h). They must mark exactly the cells of OctoMap's computeRayKeys: in
// every direction, across block boundaries, on exact ties (backward walks fall back to OctoMap's order),
// outside the scan's evidence box (overflow cells), and stopping at the culling region. Neighbouring rays
// of a ring are walked in pairs that share their steps while in the same cell: those must mark and count
// exactly what walking them one by one does, and mark the endpoints' cells hit where they end.
#include <algorithm>
#include <cmath>
#include <random>
#include <set>
#include <vector>

#include <gtest/gtest.h>
#include <octomap/OcTree.h>
#include <omp.h>

#include "densemap/geometry/ray_traversal.h"
#include "densemap/map/grid_map.h"
#include "densemap/update/ray_tracer.h"

namespace densemap::update {
namespace {

using geometry::Vec3f;
using geometry::VoxelKey;

std::set<std::uint64_t> octomapCells(const octomap::OcTree& tree, const Vec3f& o,
                                     const std::vector<SuperRay>& rays) {
  std::set<std::uint64_t> out;
  octomap::KeyRay ray;
  for (const SuperRay& r : rays) {
    if (!tree.computeRayKeys(octomap::point3d(o.x(), o.y(), o.z()),
                             octomap::point3d(r.end.x(), r.end.y(), r.end.z()), ray))
      continue;
    for (const auto& k : ray) out.insert(VoxelKey{{k[0], k[1], k[2]}}.packed());
  }
  return out;
}

std::set<std::uint64_t> markedFree(const map::ScanEvidence& ev) {
  std::set<std::uint64_t> out;
  ev.forEachBlock([&](const map::EvidenceBlock& b) {
    b.forEachEvidenceVoxel([&](int v) {
      if (b.free.test(v)) out.insert(b.voxelKey(v).packed());
    });
  });
  ev.forEachOverflowCell([&](const VoxelKey& k, std::uint32_t nf, std::uint32_t) {
    if (nf > 0) out.insert(k.packed());
  });
  return out;
}

/// Rays in every direction from an origin off the grid, plus rays from an origin on grid planes through
/// cell corners (exact ties).
std::vector<SuperRay> testRays(double res, Vec3f& origin, bool ties) {
  std::vector<SuperRay> rays;
  if (ties) {
    origin = Vec3f(0.0f, 0.0f, 0.0f);
    const float h = static_cast<float>(res);
    for (int x = -9; x <= 9; ++x)
      for (int y = -9; y <= 9; ++y)
        for (int z = -3; z <= 3; ++z)
          if (x != 0 || y != 0 || z != 0)
            rays.push_back(
                {Vec3f(h * static_cast<float>(x), h * static_cast<float>(y), h * static_cast<float>(z)), 1});
    return rays;
  }
  origin = Vec3f(0.37f, -1.21f, 1.73f);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> pos(-30.0f, 30.0f);
  for (int i = 0; i < 4000; ++i) rays.push_back({Vec3f(pos(rng), pos(rng), pos(rng) * 0.3f), 1});
  return rays;
}

void resetAround(map::ScanEvidence& ev, const geometry::KeyConverter& conv, const Vec3f& o, int half_cells) {
  VoxelKey ok;
  ASSERT_TRUE(conv.toKey(o, ok));
  VoxelKey lo, hi;
  for (int a = 0; a < 3; ++a) {
    lo[a] = static_cast<geometry::KeyCoord>(ok[a] - half_cells);
    hi[a] = static_cast<geometry::KeyCoord>(ok[a] + half_cells);
  }
  ev.reset(lo, hi, false);
}

TEST(TraceRays, BatchWalksMarkExactlyOctomapsCells) {
  for (double res : {0.1, 0.4}) {
    for (bool ties : {false, true}) {
      octomap::OcTree tree(res);
      map::GridMap grid(res);
      Vec3f o;
      const std::vector<SuperRay> rays = testRays(res, o, ties);
      const std::set<std::uint64_t> expected = octomapCells(tree, o, rays);
      ASSERT_GT(expected.size(), 1000u);
      for (bool backward : {false, true}) {
        // A box far larger than the rays, then one that cuts the random rays (cells outside go to the
        // overflow map; the tie rays stay within 9 cells).
        for (int half : {1000, 40}) {
          map::ScanEvidence ev;
          resetAround(ev, grid.converter(), o, half);
          TraceOptions opt;
          opt.backward = backward;
          const TraceCounters c = traceRays(grid, ev, o, rays, opt);
          EXPECT_EQ(markedFree(ev), expected) << "res " << res << (ties ? " ties" : " random")
                                              << (backward ? " backward" : " forward") << " box " << half;
          if (half == 40 && !ties) {
            EXPECT_GT(ev.overflowCount(), 0u) << "the small box should have cut some rays";
          }
          if (backward && ties) {
            EXPECT_GT(c.fallbacks, 0u) << "corner rays should have produced rounding ties";
          }
        }
      }
    }
  }
}

// Threads of a team mark their own lanes of the free planes (no locked operations), merged after the
// walks; threads beyond map::ScanEvidence::kMaxFreeLanes mark the shared planes with locked operations.
// Whatever the team, the cells are OctoMap's, and nothing of one scan's lanes leaks into the next.
TEST(TraceRays, ThreadTeamsMarkOctomapsCellsAndLeaveNothingForTheNextScan) {
  const double res = 0.2;
  octomap::OcTree tree(res);
  map::GridMap grid(res);
  Vec3f o_random, o_ties;
  const std::vector<SuperRay> random = testRays(res, o_random, false);
  const std::vector<SuperRay> ties = testRays(res, o_ties, true);
  const std::set<std::uint64_t> expected_random = octomapCells(tree, o_random, random);
  const std::set<std::uint64_t> expected_ties = octomapCells(tree, o_ties, ties);
  const int before = omp_get_max_threads();
  for (int team : {1, 2, 4, map::ScanEvidence::kMaxFreeLanes + 3}) {
    omp_set_num_threads(team);
    for (bool backward : {false, true}) {
      map::ScanEvidence ev;  // reused by both scans, as the engine reuses its own
      for (int scan = 0; scan < 2; ++scan) {
        const bool first = scan == 0;
        const Vec3f& o = first ? o_random : o_ties;
        resetAround(ev, grid.converter(), o, 1000);
        TraceOptions opt;
        opt.backward = backward;
        traceRays(grid, ev, o, first ? random : ties, opt);
        EXPECT_EQ(markedFree(ev), first ? expected_random : expected_ties)
            << team << " threads" << (backward ? " backward" : " forward") << " scan " << scan;
      }
    }
  }
  omp_set_num_threads(before);
}

/// A spinning sensor's rings: neighbouring rays 0.18 degrees apart (a ring's consecutive points, as
/// KITTI stores them), which the forward batch walk takes in pairs. The ranges vary from ray to ray, so
/// either of a pair ends first; some pairs end in the same cell, some rays end in the sensor's cell, and
/// one ring is level (no z steps at all).
std::vector<SuperRay> ringRays(const Vec3f& o) {
  std::vector<SuperRay> rays;
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> range(0.5f, 45.0f);
  const double kDeg = 3.14159265358979323846 / 180.0;
  for (double elevation : {-10.0, -2.0, 0.0, 3.0}) {
    for (int i = 0; i < 2000; ++i) {
      const double az = 0.18 * i * kDeg, el = elevation * kDeg;
      float r = range(rng);
      if (i % 7 == 1) r = std::sqrt((rays.back().end - o).squaredNorm());  // as far as its neighbour
      if (i % 97 == 0) r = 0.01f;                                          // ends in the sensor's cell
      const Vec3f dir(static_cast<float>(std::cos(el) * std::cos(az)),
                      static_cast<float>(std::cos(el) * std::sin(az)), static_cast<float>(std::sin(el)));
      rays.push_back({o + r * dir, 1});
    }
  }
  return rays;
}

std::uint64_t octomapTraversals(const octomap::OcTree& tree, const Vec3f& o,
                                const std::vector<SuperRay>& rays) {
  std::uint64_t n = 0;
  octomap::KeyRay ray;
  for (const SuperRay& r : rays) {
    if (tree.computeRayKeys(octomap::point3d(o.x(), o.y(), o.z()),
                            octomap::point3d(r.end.x(), r.end.y(), r.end.z()), ray))
      n += ray.size();
  }
  return n;
}

TEST(TraceRays, NeighbouringRaysWalkedInPairsMarkAndCountOctomapsCells) {
  const int before = omp_get_max_threads();
  for (double res : {0.1, 0.2, 0.4}) {
    octomap::OcTree tree(res);
    map::GridMap grid(res);
    // Off the grid, and on grid planes (rounding ties between the axes).
    for (const Vec3f& o : {Vec3f(0.37f, -1.21f, 1.73f), Vec3f(0.0f, 0.0f, 0.0f)}) {
      const std::vector<SuperRay> rays = ringRays(o);
      const std::set<std::uint64_t> expected = octomapCells(tree, o, rays);
      const std::uint64_t expected_traversals = octomapTraversals(tree, o, rays);
      for (int team : {1, 2}) {
        omp_set_num_threads(team);
        map::ScanEvidence ev;
        resetAround(ev, grid.converter(), o, 1000);
        const TraceCounters c = traceRays(grid, ev, o, rays, TraceOptions{});
        EXPECT_EQ(markedFree(ev), expected) << "res " << res << " origin " << o.transpose() << ", " << team;
        EXPECT_EQ(c.traversed, expected_traversals) << "res " << res << " origin " << o.transpose();
      }
    }
  }
  omp_set_num_threads(before);
}

// The overload the engine uses when it walks a scan's points in place (nothing rejected or cut): the same
// cells and visits as the super-ray list of weight 1, with the endpoints' keys passed in or not, forward
// (in pairs) and backward.
TEST(TraceRays, PointsWalkedInPlaceMarkOctomapsCells) {
  for (double res : {0.2, 0.4}) {
    octomap::OcTree tree(res);
    map::GridMap grid(res);
    Vec3f o;
    // Random rays (few cells shared, so a wrong ray shows), then a ring's neighbours (walked in pairs).
    std::vector<SuperRay> rays = testRays(res, o, false);
    for (const SuperRay& r : ringRays(o)) rays.push_back(r);
    std::vector<Vec3f> ends;
    std::vector<geometry::VoxelKey> keys;
    for (const SuperRay& r : rays) {
      ASSERT_EQ(r.weight, 1u);
      ends.push_back(r.end);
      geometry::VoxelKey k;
      ASSERT_TRUE(grid.converter().toKey(r.end, k));
      keys.push_back(k);
    }
    const std::set<std::uint64_t> expected = octomapCells(tree, o, rays);
    const std::uint64_t expected_traversals = octomapTraversals(tree, o, rays);
    for (bool backward : {false, true})
      for (bool with_keys : {false, true}) {
        TraceOptions opt;
        opt.backward = backward;
        if (with_keys) opt.end_keys = &keys;
        map::ScanEvidence ev;
        resetAround(ev, grid.converter(), o, 1000);
        const TraceCounters c = traceRays(grid, ev, o, ends, opt);
        EXPECT_EQ(markedFree(ev), expected)
            << "res " << res << " backward " << backward << " keys " << with_keys;
        EXPECT_EQ(c.traversed, expected_traversals) << "res " << res << " backward " << backward;
      }
  }
}

std::set<std::uint64_t> markedHit(const map::ScanEvidence& ev) {
  std::set<std::uint64_t> out;
  ev.forEachBlock([&](const map::EvidenceBlock& b) {
    b.forEachEvidenceVoxel([&](int v) {
      if (b.hit.test(v)) out.insert(b.voxelKey(v).packed());
    });
  });
  ev.forEachOverflowCell([&](const VoxelKey& k, std::uint32_t, std::uint32_t nh) {
    if (nh > 0) out.insert(k.packed());
  });
  return out;
}

// The forward pair walks of a scan's endpoints mark each endpoint's cell hit where they end (the engine
// then skips its own pass over the endpoints). Every endpoint cell must be hit: those the walks reach, rays
// ending in the sensor's cell, rays ending on cell corners from an origin on grid planes (where OctoMap's
// rounding can stop a walk short of its end cell) and cells outside the evidence box (overflow). The counts
// the default method's rule reads must be those of the engine's pass: distinct endpoint cells inside the
// box, and the walk lengths of the other endpoints. Walks that do not mark hits (backward, or rays given
// without the endpoints' keys) must say so and leave them alone.
TEST(TraceRays, ForwardPairWalksMarkTheEndpointsHit) {
  const int before = omp_get_max_threads();
  for (double res : {0.2, 0.4}) {
    map::GridMap grid(res);
    const auto& conv = grid.converter();
    for (bool ties : {false, true}) {
      Vec3f o;
      std::vector<SuperRay> rays = testRays(res, o, ties);  // random rays, or rays to cell corners
      for (const SuperRay& r : ringRays(o)) rays.push_back(r);
      std::vector<Vec3f> ends;
      std::vector<VoxelKey> keys;
      for (const SuperRay& r : rays) {
        ends.push_back(r.end);
        VoxelKey k;
        ASSERT_TRUE(conv.toKey(r.end, k));
        keys.push_back(k);
      }
      VoxelKey ok;
      ASSERT_TRUE(conv.toKey(o, ok));
      // A box smaller than the rays' reach: part of the endpoints are overflow cells.
      const int half_cells = static_cast<int>(std::lround(20.0 / res));
      for (int team : {1, 2}) {
        omp_set_num_threads(team);
        map::ScanEvidence ev;
        resetAround(ev, conv, o, half_cells);
        std::set<std::uint64_t> expected_hits, inside;
        std::uint64_t expected_shared = 0;  // in ray order, as one thread walks them
        for (const VoxelKey& k : keys) {
          const bool first = expected_hits.insert(k.packed()).second && ev.insideBox(k);
          if (first) inside.insert(k.packed());
          if (!first)
            for (int a = 0; a < 3; ++a) expected_shared += static_cast<std::uint64_t>(std::abs(k[a] - ok[a]));
        }
        ASSERT_GT(inside.size(), 100u);
        ASSERT_GT(expected_hits.size(), inside.size() + 100u) << "some endpoints must be overflow cells";
        TraceOptions opt;
        opt.end_keys = &keys;
        const TraceCounters c = traceRays(grid, ev, o, ends, opt);
        EXPECT_TRUE(c.hits_marked);
        EXPECT_EQ(markedHit(ev), expected_hits) << "res " << res << " ties " << ties << ", team " << team;
        EXPECT_EQ(c.hit_cells, inside.size()) << "res " << res << ", " << team;
        if (team == 1) {
          EXPECT_EQ(c.shared_walks, expected_shared) << "res " << res << " ties " << ties;
        }
      }
      omp_set_num_threads(before);
      for (bool backward : {false, true}) {
        TraceOptions opt;
        opt.backward = backward;
        if (backward) opt.end_keys = &keys;  // forward: without the keys, the rays are not the endpoints
        map::ScanEvidence ev;
        resetAround(ev, conv, o, half_cells);
        const TraceCounters c = traceRays(grid, ev, o, ends, opt);
        EXPECT_FALSE(c.hits_marked) << "backward " << backward;
        EXPECT_TRUE(markedHit(ev).empty()) << "backward " << backward;
        EXPECT_EQ(c.hit_cells, 0u);
      }
    }
  }
  omp_set_num_threads(before);
}

TEST(TraceRays, BackwardBatchWalksStopOnEnteringTheRegion) {
  const double res = 0.2;
  octomap::OcTree tree(res);
  map::GridMap grid(res);
  Vec3f o;
  const std::vector<SuperRay> rays = testRays(res, o, false);
  map::ScanEvidence ev;
  resetAround(ev, grid.converter(), o, 1000);
  // Region: every cell within 12 cells of the sensor's cell (a ball is closed toward the sensor, as
  // Alg. 3's region is, so each ray's cells inside it come after all its cells outside it).
  VoxelKey ok;
  ASSERT_TRUE(grid.converter().toKey(o, ok));
  auto inBall = [&](const VoxelKey& k) {
    int d2 = 0;
    for (int a = 0; a < 3; ++a) d2 += (k[a] - ok[a]) * (k[a] - ok[a]);
    return d2 <= 144;
  };
  std::set<std::uint64_t> expected;
  octomap::KeyRay ray;
  for (const SuperRay& r : rays) {
    ASSERT_TRUE(tree.computeRayKeys(octomap::point3d(o.x(), o.y(), o.z()),
                                    octomap::point3d(r.end.x(), r.end.y(), r.end.z()), ray));
    std::vector<VoxelKey> cells;
    for (const auto& k : ray) cells.push_back(VoxelKey{{k[0], k[1], k[2]}});
    // Walked from the end: marked until the first cell in the region.
    for (auto it = cells.rbegin(); it != cells.rend() && !inBall(*it); ++it) expected.insert(it->packed());
  }
  for (int dx = -12; dx <= 12; ++dx)
    for (int dy = -12; dy <= 12; ++dy)
      for (int dz = -12; dz <= 12; ++dz) {
        const VoxelKey k{{static_cast<geometry::KeyCoord>(ok[0] + dx),
                          static_cast<geometry::KeyCoord>(ok[1] + dy),
                          static_cast<geometry::KeyCoord>(ok[2] + dz)}};
        if (!inBall(k)) continue;
        map::EvidenceBlock* b = ev.block(k);
        ASSERT_NE(b, nullptr);
        b->region.set(map::voxelIndexInBlock(k));
      }
  ev.noteRegionsUsed();
  TraceOptions opt;
  opt.backward = true;
  opt.region = true;
  traceRays(grid, ev, o, rays, opt);
  const std::set<std::uint64_t> got = markedFree(ev);
  EXPECT_EQ(got, expected);
  EXPECT_LT(got.size(), octomapCells(tree, o, rays).size()) << "the region should have cut the walks";
}

}  // namespace
}  // namespace densemap::update
