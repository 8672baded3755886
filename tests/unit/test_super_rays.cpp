// Super rays (Sec. 2.3.2-2.3.4): every ray grouped into a super ray traverses exactly the cells of the
// super ray's representative, by OctoMap's own computeRayKeys.
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include "densemap/io/lidar_simulator.h"
#include "densemap/sources/open_source.h"
#include "densemap/update/super_ray_generator.h"
#include "test_data.h"

namespace densemap::update {
namespace {

std::vector<octomap::OcTreeKey> octomapCells(const octomap::OcTree& tree, const geometry::Vec3f& o,
                                             const geometry::Vec3f& e) {
  // One KeyRay for all calls: each holds 100,000 keys, and a fresh one per ray made this file take minutes
  // under the sanitizers.
  static thread_local octomap::KeyRay ray;
  tree.computeRayKeys(octomap::point3d(o.x(), o.y(), o.z()), octomap::point3d(e.x(), e.y(), e.z()), ray);
  return {ray.begin(), ray.end()};
}

/// Checks the property and returns the number of points that were grouped with others.
std::size_t checkMembersTraverseRepresentativeCells(double res, const geometry::Vec3f& origin,
                                                    const std::vector<geometry::Vec3f>& ends,
                                                    std::uint32_t k) {
  octomap::OcTree tree(res);
  geometry::KeyConverter conv(res);
  SuperRayGenerator gen(SuperRayOptions{k});
  std::vector<SuperRay> rays;
  std::vector<std::uint32_t> assignment;
  SuperRayStats st;
  gen.generate(conv, origin, ends, rays, &st, &assignment);
  EXPECT_EQ(st.points, ends.size());
  std::uint64_t total_weight = 0;
  for (const auto& r : rays) total_weight += r.weight;
  EXPECT_EQ(total_weight, ends.size()) << "every point is represented exactly once";
  std::size_t grouped = 0;
  for (std::size_t i = 0; i < ends.size(); ++i) {
    const SuperRay& r = rays.at(assignment[i]);
    if (r.weight > 1) ++grouped;
    EXPECT_EQ(octomapCells(tree, origin, ends[i]), octomapCells(tree, origin, r.end)) << "point " << i;
  }
  return grouped;
}

TEST(SuperRays, RandomRaysInOneSuperRayTraverseIdenticalCells) {
  // Dense clusters of random endpoints around random cells, so many rays share a cell.
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> centre(-25.0f, 25.0f), jitter(-0.12f, 0.12f);
  std::vector<geometry::Vec3f> ends;
  for (int c = 0; c < 60; ++c) {
    const geometry::Vec3f ctr(centre(rng), centre(rng), centre(rng) * 0.2f);
    for (int i = 0; i < 200; ++i)
      ends.emplace_back(ctr.x() + jitter(rng), ctr.y() + jitter(rng), ctr.z() + jitter(rng));
  }
  const std::size_t grouped = checkMembersTraverseRepresentativeCells(0.4, {0.13f, -0.31f, 1.7f}, ends, 2);
  EXPECT_GT(grouped, ends.size() / 4) << "dense cells should group many rays";
}

TEST(SuperRays, OriginOnGridPlanes) {
  // KITTI's first pose sits exactly at (0, 0, 0), on three grid planes: OctoMap's planes are offset by a
  // float rounding of res/2 there, and the grouping must follow them.
  std::mt19937 rng(9);
  std::uniform_real_distribution<float> u(-12.0f, 12.0f);
  std::vector<geometry::Vec3f> ends;
  for (int i = 0; i < 20000; ++i)
    ends.emplace_back(u(rng) * 0.3f + 4.0f, u(rng) * 0.3f - 3.0f, u(rng) * 0.05f);
  checkMembersTraverseRepresentativeCells(0.2, {0.0f, 0.0f, 0.0f}, ends, 2);
}

TEST(SuperRays, SimulatedScanAtCoarseResolution) {
  io::LidarSimulatorOptions o;
  o.scans = 1;
  io::LidarSimulator sim(o);
  const io::Scan s = sim.read(0);
  const std::size_t grouped = checkMembersTraverseRepresentativeCells(0.8, s.origin(), s.worldPoints(), 20);
  EXPECT_GT(grouped, s.points.size() / 4);
}

TEST(SuperRays, RealScanKitti) {
  DENSEMAP_REQUIRE_DATA("kitti00");
  auto src = sources::openSource(test::dataDir() + "/kitti00");
  const io::Scan s = src->read(3);
  checkMembersTraverseRepresentativeCells(0.4, s.origin(), s.worldPoints(), 20);
}

TEST(SuperRays, ThresholdKeepsSparseCellsSingle) {
  std::vector<geometry::Vec3f> ends;
  for (int i = 0; i < 19; ++i) ends.emplace_back(5.05f + 0.01f * static_cast<float>(i), 0.5f, 0.5f);
  geometry::KeyConverter conv(1.0);
  SuperRayGenerator gen(SuperRayOptions{20});
  EXPECT_EQ(gen.generate(conv, {0.5f, 0.5f, 0.5f}, ends).size(), 19u) << "19 points < k = 20";
  ends.emplace_back(5.9f, 0.5f, 0.5f);
  EXPECT_LT(gen.generate(conv, {0.5f, 0.5f, 0.5f}, ends).size(), 20u) << "20 points reach k";
}

}  // namespace
}  // namespace densemap::update
