// The map window over the dense layer: with --window-radius, dense blocks farther than the
// radius from every robot are dropped after each scan, so the layer's memory follows the robots instead of
// the distance driven; within the radius it is exactly the layer the same scans build without a window.
#include <gtest/gtest.h>

#include <filesystem>
#include <span>

#include "densemap/dense/dense_layer_factory.h"
#include "densemap/server/map_service.h"
#include "map_service_helpers.h"
#include "temp_dir.h"

namespace densemap::test {
namespace {

using namespace server;
namespace fs = std::filesystem;

TEST(DenseWindow, TheLayerDropsExactlyTheBlocksBeyondTheRadius) {
  dense::DenseLayerOptions o;
  o.method = "bgk";
  o.max_range = 20.0;
  auto layer = dense::makeDenseLayer(o, 0.2);
  const io::Scan scan = simScans(1)[0];
  layer->insert(scan.worldPoints(), scan.origin());
  const std::size_t before = layer->blockCount();
  const geometry::Vec3f origin = scan.origin();
  const double radius = 8.0;
  const std::vector<geometry::Vec3f> centres{origin};
  const auto far = layer->blocksFartherThan(std::span(centres), radius);
  ASSERT_GT(far.size(), 0u);
  ASSERT_LT(far.size(), before);
  // Evidence of sample points well inside and well outside the radius (8^3-cell blocks of 1.6 m: a block
  // centre is within 1.4 m of each of its cells).
  std::vector<geometry::VoxelKey> inside, outside;
  for (const auto& p : scan.worldPoints()) {
    geometry::VoxelKey k;
    if (!layer->converter().toKey(p, k)) continue;
    const auto e = layer->evidence(k);
    if (e[0] + e[1] == 0.0f) continue;
    const float d = (p - origin).norm();
    if (d < radius - 1.5) inside.push_back(k);
    if (d > radius + 1.5) outside.push_back(k);
  }
  ASSERT_GT(inside.size(), 100u);
  ASSERT_GT(outside.size(), 100u);
  std::vector<std::array<float, 2>> kept;
  for (const auto& k : inside) kept.push_back(layer->evidence(k));
  EXPECT_EQ(layer->dropBlocks(far), far.size());
  EXPECT_EQ(layer->blockCount(), before - far.size());
  for (std::size_t i = 0; i < inside.size(); ++i) EXPECT_EQ(layer->evidence(inside[i]), kept[i]);
  for (const auto& k : outside) EXPECT_EQ(layer->evidence(k), (std::array<float, 2>{0.0f, 0.0f}));
  EXPECT_TRUE(layer->blocksFartherThan(std::span(centres), radius).empty()) << "nothing left to drop";
}

ServiceOptions denseOptions(const fs::path& dir, double radius) {
  ServiceOptions o;
  o.data_dir = dir.string();
  o.update_nice = 0;
  o.durability.journal = false;
  o.dense.method = "bgk";
  o.dense.max_range = 10.0;
  o.dense_overflow = OverflowPolicy::kWait;  // every scan reaches the layer: comparable with the other
  o.window.radius_m = radius;
  return o;
}

TEST(DenseWindow, TheServiceKeepsTheDenseLayerNearTheRobotsAndExactThere) {
  TempDir tmp;
  io::LidarSimulator sim(smallSimulator(14, 32, 512, 2.0));  // 2 m per scan: 26 m driven
  std::vector<io::Scan> scans;
  for (int i = 0; i < 14; ++i) scans.push_back(sim.read(static_cast<std::size_t>(i)));
  MapService windowed(denseOptions(tmp.path / "w", 16.0)), whole(denseOptions(tmp.path / "a", 0.0));
  for (MapService* s : {&windowed, &whole}) {
    Outcomes out;
    for (std::size_t i = 0; i < scans.size(); ++i)
      ASSERT_TRUE(s->submit(jobOf(scans[i], "r0", i), out.callback()).accepted);
    ASSERT_TRUE(out.waitFor(scans.size()));
    s->stop(true);  // drains the dense stage as well
  }
  const auto w = windowed.windowStats();
  ASSERT_TRUE(w);
  EXPECT_GT(w->dense_blocks_dropped, 0u);
  const auto blocks = [](MapService& s) {
    return s.denseStore()->read([](const dense::KernelLayer& l, std::uint64_t) { return l.blockCount(); });
  };
  EXPECT_LT(blocks(windowed), blocks(whole));
  EXPECT_EQ(blocks(whole) - blocks(windowed), w->dense_blocks_dropped)
      << "a dropped block is never touched again: rays reach 10 m (plus kernels), the radius is 16 m";
  // Around the robot both layers answer the same, bit for bit; around the start only the whole one knows.
  const geometry::Vec3f here = scans.back().origin(), start = scans.front().origin();
  std::vector<geometry::Vec3f> near, behind;
  for (const auto& p : scans.back().worldPoints())
    if ((p - here).norm() < 8.0f) near.push_back(p);
  for (const auto& p : scans.front().worldPoints())
    if ((p - start).norm() < 8.0f && (p - here).norm() > 18.0f) behind.push_back(p);
  ASSERT_GT(near.size(), 100u);
  ASSERT_GT(behind.size(), 100u);
  const auto dense = [](MapService& s, const std::vector<geometry::Vec3f>& pts) {
    const Answer a = s.answer(PointsQuery{pts, Layer::kDense});
    EXPECT_EQ(a.status, Status::kOk) << a.message;
    return std::get<PointsAnswer>(a.result);
  };
  const PointsAnswer wn = dense(windowed, near), an = dense(whole, near);
  EXPECT_EQ(wn.probabilities, an.probabilities);
  EXPECT_GT(std::count(an.states.begin(), an.states.end(), CellState::kOccupied), 10);
  const PointsAnswer wb = dense(windowed, behind), ab = dense(whole, behind);
  EXPECT_EQ(std::count(wb.states.begin(), wb.states.end(), CellState::kUnknown),
            static_cast<std::ptrdiff_t>(behind.size()));
  EXPECT_GT(std::count(ab.states.begin(), ab.states.end(), CellState::kOccupied), 10);
}

}  // namespace
}  // namespace densemap::test
