// The forward walk reproduces OctoMap's computeRayKeys cell for cell; the backward walk visits the same
// cells in reverse, including rays whose crossings tie exactly (where it must fall back to OctoMap's order).
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include "densemap/geometry/ray_traversal.h"

namespace densemap::geometry {
namespace {

std::vector<VoxelKey> octomapRay(const octomap::OcTree& tree, const Vec3f& o, const Vec3f& e) {
  static thread_local octomap::KeyRay ray;  // 100,000 keys: one per call is slow under the sanitizers
  std::vector<VoxelKey> out;
  if (!tree.computeRayKeys(octomap::point3d(o.x(), o.y(), o.z()), octomap::point3d(e.x(), e.y(), e.z()), ray))
    return out;
  for (const auto& k : ray) out.push_back(VoxelKey{{k[0], k[1], k[2]}});
  return out;
}

std::vector<VoxelKey> forward(const KeyConverter& conv, const Vec3f& o, const Vec3f& e) {
  std::vector<VoxelKey> out;
  RaySetup r;
  if (setupRay(conv, o, e, r)) walkForward(r, [&](const VoxelKey& k) { out.push_back(k); });
  return out;
}

std::vector<VoxelKey> backward(const KeyConverter& conv, const Vec3f& o, const Vec3f& e,
                               WalkStats* ws = nullptr) {
  std::vector<VoxelKey> out;
  RaySetup r;
  if (setupRay(conv, o, e, r))
    walkBackward(
        r, [](const VoxelKey&) { return false; }, [&](const VoxelKey& k) { out.push_back(k); }, ws);
  return out;
}

void expectSameCells(std::vector<VoxelKey> expected, std::vector<VoxelKey> got, const char* what) {
  std::sort(expected.begin(), expected.end(), [](auto& a, auto& b) { return a.packed() < b.packed(); });
  std::sort(got.begin(), got.end(), [](auto& a, auto& b) { return a.packed() < b.packed(); });
  EXPECT_EQ(expected, got) << what;
}

TEST(RayTraversal, ForwardMatchesOctomapOnRandomRays) {
  for (double res : {0.1, 0.2, 0.35, 1.0}) {
    octomap::OcTree tree(res);
    KeyConverter conv(res);
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> pos(-60.0f, 60.0f), org(-3.0f, 3.0f);
    for (int i = 0; i < 3000; ++i) {
      const Vec3f o(org(rng), org(rng), org(rng) * 0.3f);
      const Vec3f e(pos(rng), pos(rng), pos(rng) * 0.2f);
      EXPECT_EQ(octomapRay(tree, o, e), forward(conv, o, e)) << "res " << res << " ray " << i;
    }
  }
}

TEST(RayTraversal, BackwardVisitsTheSameCellsInReverse) {
  const double res = 0.2;
  octomap::OcTree tree(res);
  KeyConverter conv(res);
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> pos(-40.0f, 40.0f);
  for (int i = 0; i < 3000; ++i) {
    const Vec3f o(0.37f, -1.21f, 1.73f);
    const Vec3f e(pos(rng), pos(rng), pos(rng) * 0.1f);
    std::vector<VoxelKey> fwd = octomapRay(tree, o, e);
    std::vector<VoxelKey> bwd = backward(conv, o, e);
    std::reverse(bwd.begin(), bwd.end());
    EXPECT_EQ(fwd, bwd) << "ray " << i;
  }
}

TEST(RayTraversal, ExactTiesFallBackToOctomapOrder) {
  // Origin exactly on grid planes and rays through cell corners: crossings tie, and OctoMap's tie-breaking
  // and rounding decide the cells. The backward walk must detect the ties and still agree.
  const double res = 0.5;
  octomap::OcTree tree(res);
  KeyConverter conv(res);
  WalkStats ws;
  int rays = 0;
  for (int x = -6; x <= 6; ++x)
    for (int y = -6; y <= 6; ++y)
      for (int z = -2; z <= 2; ++z) {
        if (x == 0 && y == 0 && z == 0) continue;
        const Vec3f o(0.0f, 0.0f, 0.0f);
        const Vec3f e(0.5f * static_cast<float>(x), 0.5f * static_cast<float>(y),
                      0.5f * static_cast<float>(z));
        std::vector<VoxelKey> fwd = octomapRay(tree, o, e);
        EXPECT_EQ(fwd, forward(conv, o, e)) << x << " " << y << " " << z;
        expectSameCells(fwd, backward(conv, o, e, &ws), "backward on a tie");
        ++rays;
      }
  EXPECT_GT(ws.fallbacks, 0u) << "the corner rays should have produced rounding ties";
  EXPECT_GT(rays, 0);
}

TEST(RayTraversal, BackwardStopsOnEnteringTheRegion) {
  const double res = 0.2;
  KeyConverter conv(res);
  const Vec3f o(0.05f, 0.05f, 0.05f), e(9.3f, 2.1f, 0.7f);
  RaySetup r;
  ASSERT_TRUE(setupRay(conv, o, e, r));
  std::vector<VoxelKey> all;
  walkForward(r, [&](const VoxelKey& k) { all.push_back(k); });
  ASSERT_GT(all.size(), 20u);
  // A region holding the first 10 cells from the origin (what a culling region looks like along a ray).
  const std::vector<VoxelKey> region(all.begin(), all.begin() + 10);
  auto in = [&](const VoxelKey& k) { return std::find(region.begin(), region.end(), k) != region.end(); };
  std::vector<VoxelKey> visited;
  walkBackward(r, in, [&](const VoxelKey& k) { visited.push_back(k); });
  std::reverse(visited.begin(), visited.end());
  EXPECT_EQ(std::vector<VoxelKey>(all.begin() + 10, all.end()), visited);
}

TEST(RayTraversal, MaxRangeCutMatchesOctomap) {
  const Vec3f o(1.0f, 2.0f, 0.5f), p(40.0f, -12.0f, 3.0f);
  const ClippedRay c = clipRay(o, p, 10.0);
  EXPECT_FALSE(c.hit);
  // OctoMap: origin + (p - origin).normalized() * (float)maxrange.
  const octomap::point3d op(o.x(), o.y(), o.z()), pp(p.x(), p.y(), p.z());
  const octomap::point3d expected = op + (pp - op).normalized() * 10.0f;
  EXPECT_EQ(expected.x(), c.end.x());
  EXPECT_EQ(expected.y(), c.end.y());
  EXPECT_EQ(expected.z(), c.end.z());
  EXPECT_TRUE(clipRay(o, p, -1.0).hit);
  EXPECT_TRUE(clipRay(o, p, 100.0).hit);
}

TEST(RayTraversal, KeysMatchOctomap) {
  octomap::OcTree tree(0.2);
  KeyConverter conv(0.2);
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> pos(-500.0f, 500.0f);
  for (int i = 0; i < 10000; ++i) {
    const Vec3f p(pos(rng), pos(rng), pos(rng));
    octomap::OcTreeKey ok(0, 0, 0);
    VoxelKey k;
    ASSERT_EQ(tree.coordToKeyChecked(octomap::point3d(p.x(), p.y(), p.z()), ok), conv.toKey(p, k));
    EXPECT_EQ((VoxelKey{{ok[0], ok[1], ok[2]}}), k);
  }
  VoxelKey k;
  EXPECT_FALSE(conv.toKey(Vec3f(1e5f, 0.0f, 0.0f), k)) << "beyond the 16-bit key range";
}

}  // namespace
}  // namespace densemap::geometry
