// The mapping line (Sec. 2.3.1, Alg. 1) on 2D cases small enough to check by hand: the situations of
// Fig. 2.5 (grid points of each slice's "out" line projected onto the line) and Fig. 2.6 (five rays, three
// segments, three super rays).
#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include "densemap/update/mapping_line.h"
#include "densemap/update/super_ray_generator.h"

namespace densemap::update {
namespace {

using geometry::KeyConverter;
using geometry::kKeyCenter;

// Resolution 1, origin at (0.5, 0.5) (cell (0, 0)); cell c = [3,4] x [1,2] (keys +3, +1). Processing
// direction x (the cell is 3 slices away in x, 1 in y). The seed frustum spans slopes 1/7 .. 0.6.
//  - out line x = 1: frustum covers y in [0.57, 0.80]: no grid point;
//  - out line x = 2: y in [0.71, 1.40]: grid point (2, 1), slope 0.5 / 1.5 = 1/3;
//  - out line x = 3: y in [0.86, 2.00]: grid points (3, 1) and (3, 2), slopes 0.2 and 0.6.
// Segments: [1/7, 0.2) below (3, 1); [0.2, 1/3) between; [1/3, 0.6) above (2, 1).
struct Fig25 : ::testing::Test {
  KeyConverter conv{1.0};
  GridPlanes px{conv, kKeyCenter}, py{conv, kKeyCenter};
  MappingLine line;
  void SetUp() override {
    line.build(0.5, 0.5, kKeyCenter, kKeyCenter, kKeyCenter + 3, kKeyCenter + 1, px, py);
  }
};

TEST_F(Fig25, ProjectsTheGridPointsOfEachSlice) {
  ASSERT_EQ(line.projections().size(), 3u);
  EXPECT_DOUBLE_EQ(line.projections()[0], 0.2);
  EXPECT_DOUBLE_EQ(line.projections()[1], 1.0 / 3.0);
  EXPECT_DOUBLE_EQ(line.projections()[2], 0.6);
  EXPECT_EQ(line.segments(), 4u);
}

TEST_F(Fig25, ClassifiesRaysBySegment) {
  EXPECT_EQ(line.classify(3.9, 1.05), 0);  // slope 0.16: passes below (3, 1)
  EXPECT_EQ(line.classify(3.2, 1.30), 1);  // slope 0.30: between (3, 1) and (2, 1)
  EXPECT_EQ(line.classify(3.7, 1.20), 1);  // slope 0.22
  EXPECT_EQ(line.classify(3.5, 1.60), 2);  // slope 0.37: above (2, 1)
  EXPECT_EQ(line.classify(3.1, 1.90), 2);  // slope 0.54
}

TEST_F(Fig25, RaysThroughAGridPointAreKeptApart) {
  // Exactly through (3, 1): slope 0.2. Floating-point rounding decides its cells, so it gets no segment.
  EXPECT_EQ(line.classify(3.5, 1.1), -1);
}

TEST_F(Fig25, EachSegmentIsOneTraversalPattern) {
  // In 3D with z fixed at the cell centre the walk is the 2D one; OctoMap's own ray keys must agree within a
  // segment and differ between segments.
  octomap::OcTree tree(1.0);
  octomap::KeyRay ray;  // 100,000 keys: one for every call
  auto cells = [&](double x, double y) {
    tree.computeRayKeys(octomap::point3d(0.5f, 0.5f, 0.5f), octomap::point3d(float(x), float(y), 0.5f), ray);
    return std::vector<octomap::OcTreeKey>(ray.begin(), ray.end());
  };
  std::vector<std::vector<octomap::OcTreeKey>> pattern(3);
  for (int i = 1; i < 40; ++i)
    for (int j = 1; j < 40; ++j) {
      const double x = 3.0 + i / 40.0, y = 1.0 + j / 40.0;
      const int s = line.classify(x, y);
      if (s < 0) continue;
      ASSERT_GE(s, 0);
      ASSERT_LE(s, 2);
      const auto c = cells(x, y);
      if (pattern[static_cast<std::size_t>(s)].empty()) pattern[static_cast<std::size_t>(s)] = c;
      EXPECT_EQ(pattern[static_cast<std::size_t>(s)], c) << "segment " << s << " ray to " << x << "," << y;
    }
  EXPECT_NE(pattern[0], pattern[1]);
  EXPECT_NE(pattern[1], pattern[2]);
  EXPECT_NE(pattern[0], pattern[2]);
  // Below (3, 1) the ray runs along row 0 to x = 3, then steps up into the cell.
  EXPECT_EQ(pattern[0].size(), 4u);
}

TEST(MappingLine, Fig26FiveRaysBecomeThreeSuperRays) {
  KeyConverter conv(1.0);
  const geometry::Vec3f origin(0.5f, 0.5f, 0.5f);
  const std::vector<geometry::Vec3f> ends = {
      {3.9f, 1.05f, 0.5f}, {3.2f, 1.3f, 0.5f}, {3.5f, 1.6f, 0.5f}, {3.7f, 1.2f, 0.5f}, {3.1f, 1.9f, 0.5f}};
  SuperRayGenerator gen(SuperRayOptions{2});
  std::vector<std::uint32_t> assignment;
  std::vector<SuperRay> rays;
  SuperRayStats st;
  gen.generate(conv, origin, ends, rays, &st, &assignment);
  ASSERT_EQ(rays.size(), 3u);
  std::vector<std::uint32_t> weights;
  for (const auto& r : rays) weights.push_back(r.weight);
  std::sort(weights.begin(), weights.end());
  EXPECT_EQ(weights, (std::vector<std::uint32_t>{1, 2, 2}));
  EXPECT_EQ(assignment[1], assignment[3]);  // both in [0.2, 1/3)
  EXPECT_EQ(assignment[2], assignment[4]);  // both in [1/3, 0.6)
  EXPECT_NE(assignment[0], assignment[1]);
  EXPECT_NE(assignment[1], assignment[2]);
  EXPECT_EQ(st.super_rays, 2u);
}

TEST(MappingLine, SameCellAsOriginIsOneSegment) {
  KeyConverter conv(1.0);
  GridPlanes p(conv, kKeyCenter);
  MappingLine line;
  line.build(0.5, 0.5, kKeyCenter, kKeyCenter, kKeyCenter, kKeyCenter, p, p);
  EXPECT_EQ(line.segments(), 1u);
  EXPECT_EQ(line.classify(0.9, 0.1), 0);
}

TEST(MappingLine, ProcessingAxisFollowsTheLargerOffset) {
  // Cell mostly along y: the line must be built along y (slopes x/y stay bounded).
  KeyConverter conv(1.0);
  GridPlanes p(conv, kKeyCenter);
  MappingLine line;
  line.build(0.5, 0.5, kKeyCenter, kKeyCenter, kKeyCenter + 1, kKeyCenter + 3, p, p);
  ASSERT_EQ(line.projections().size(), 3u);  // the mirror image of Fig25
  EXPECT_DOUBLE_EQ(line.projections()[1], 1.0 / 3.0);
}

TEST(MappingLine, SegmentIsTheCountOfProjectionsAtOrBelowTheSlope) {
  // classify's search (without data-dependent branches) against std::upper_bound over the projections, on
  // cells 1-60 cells away in every direction (lines of 0 to ~60 projections) and random rays into them.
  KeyConverter conv(0.2);
  const double ou = 0.37, ov = -0.11;
  geometry::KeyCoord ku = 0, kv = 0;
  ASSERT_TRUE(conv.toKey(ou, ku) && conv.toKey(ov, kv));
  GridPlanes pu(conv, ku), pv(conv, kv);
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> offset(-60, 60);
  std::uniform_real_distribution<double> inside(0.0, 1.0);
  MappingLine line;
  std::size_t checked = 0, lines_with_many = 0;
  for (int c = 0; c < 400; ++c) {
    const int cu = pu.origin_key + offset(rng), cv = pv.origin_key + offset(rng);
    line.build(ou, ov, pu.origin_key, pv.origin_key, cu, cv, pu, pv);
    const auto& proj = line.projections();
    lines_with_many += proj.size() >= 16 ? 1 : 0;
    const bool swapped = std::abs(cv - pv.origin_key) > std::abs(cu - pu.origin_key);
    for (int r = 0; r < 50; ++r) {
      const double u = conv.toCoord(static_cast<geometry::KeyCoord>(cu)) + (inside(rng) - 0.5) * 0.2;
      const double v = conv.toCoord(static_cast<geometry::KeyCoord>(cv)) + (inside(rng) - 0.5) * 0.2;
      const int got = line.classify(u, v);
      if (cu == pu.origin_key && cv == pv.origin_key) {
        EXPECT_EQ(got, 0);
        continue;
      }
      const double m = swapped ? (u - ou) / (v - ov) : (v - ov) / (u - ou);
      const auto it = std::upper_bound(proj.begin(), proj.end(), m);
      const bool near_point = std::any_of(proj.begin(), proj.end(), [&](double g) {
        return std::fabs(m - g) <= kSlopeTolerance * (std::fabs(m) + std::fabs(g)) + 1e-300;
      });
      if (near_point) continue;  // -1 there, or its neighbour's index when the nearest is not adjacent
      EXPECT_EQ(got, static_cast<int>(it - proj.begin()))
          << "cell " << cu << "," << cv << " ray " << u << "," << v;
      ++checked;
    }
  }
  EXPECT_GT(checked, 15'000u);
  EXPECT_GT(lines_with_many, 100u) << "the lines should include long ones";
}

}  // namespace
}  // namespace densemap::update
