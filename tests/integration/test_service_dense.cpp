// The dense layer in the service: a stage after the exact map; the dense layer answers from it, the fused
// layer from the exact map where it observed a cell and from the dense layer elsewhere.
#include <sys/resource.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "densemap/dense/dense_layer_factory.h"
#include "service_harness.h"

namespace densemap::test {
namespace {

using geometry::Vec3f;

TEST(ServiceDense, DenseAndFusedLayersAnswerFromTheirMaps) {
  auto o = serverOptions(150);
  o.dense.method = "akimap";
  o.dense.max_range = 30.0;
  ServiceHarness h(o);
  const auto scans = simScans(3);
  // One scan at a time, so the dense stage (which may drop scans when behind) sees all of them.
  for (std::size_t i = 0; i < scans.size(); ++i) {
    ASSERT_TRUE(h.robot->publish("robot-0", i, scans[i]));
    for (int w = 0; w < 600 && h.server->denseStore()->version() < i + 1; ++w)
      std::this_thread::sleep_for(50ms);
    ASSERT_EQ(h.server->denseStore()->version(), i + 1) << "the dense stage did not take scan " << i;
  }
  // The same scans offline (same seed): equal up to the order of floating-point additions.
  // Built by the same factory from the same options the server was given.
  const auto offline_layer = dense::makeDenseLayer(o.dense, o.map.resolution);
  dense::KernelLayer& offline = *offline_layer;
  const auto exact = offlineMap<map::GridMap>(scans, o.map.resolution);
  for (const auto& s : scans) {
    const io::Scan sent = asSent(s);
    offline.insert(sent.worldPoints(), sent.origin());
  }
  msg::QueryRequest rq;
  rq.kind(msg::QUERY_POINTS);
  std::vector<Vec3f> probes;
  for (float x = -20; x <= 20; x += 0.7f)
    for (float y = -12; y <= 12; y += 0.9f)
      for (float z = -0.5f; z <= 3.0f; z += 0.7f) probes.emplace_back(x, y, z);
  for (const auto& p : probes) rq.points().insert(rq.points().end(), {p.x(), p.y(), p.z()});
  rq.layer(msg::LAYER_DENSE);
  const auto dense_reply = h.query->call(rq, 30s);
  ASSERT_EQ(dense_reply.status(), msg::STATUS_OK) << dense_reply.message();
  rq.layer(msg::LAYER_FUSED);
  const auto fused_reply = h.query->call(rq, 30s);
  ASSERT_EQ(fused_reply.status(), msg::STATUS_OK) << fused_reply.message();
  std::size_t dense_known = 0, fused_from_dense = 0;
  for (std::size_t i = 0; i < probes.size(); ++i) {
    const auto want = offline.probability(probes[i]);
    ASSERT_EQ(dense_reply.states()[i] != msg::CELL_UNKNOWN, want.has_value()) << "probe " << i;
    if (want) {
      ++dense_known;
      EXPECT_NEAR(dense_reply.probabilities()[i], *want, 1e-4f) << "probe " << i;
    }
    geometry::VoxelKey k;
    ASSERT_TRUE(exact->converter().toKey(probes[i], k));
    if (const auto v = exact->logOdds(k)) {
      EXPECT_EQ(fused_reply.probabilities()[i], probability(*v)) << "fused must answer from the exact map";
    } else {
      EXPECT_EQ(fused_reply.probabilities()[i], dense_reply.probabilities()[i]);
      fused_from_dense += want.has_value();
    }
  }
  EXPECT_GT(dense_known, probes.size() / 10);
  EXPECT_GT(fused_from_dense, 0u) << "the dense layer should fill cells the exact map never observed";
  const auto stats = h.server->statistics();
  // journal, occupancy, dense, then the pseudo-stages: queries, map-publish, map-read-wait
  ASSERT_EQ(stats.stages().size(), 6u);
  EXPECT_EQ(stats.stages()[0].name(), "journal");
  EXPECT_EQ(stats.stages()[2].name(), "dense");
}

/// Nice values of this process's threads named `name`.
std::vector<int> threadNice(const std::string& name) {
  std::vector<int> nice;
  for (const auto& task : std::filesystem::directory_iterator("/proc/self/task")) {
    std::ifstream comm(task.path() / "comm");
    std::string n;
    std::getline(comm, n);
    if (n == name)
      nice.push_back(getpriority(PRIO_PROCESS, static_cast<id_t>(std::stoi(task.path().filename()))));
  }
  return nice;
}

TEST(ServiceDense, TheDenseStageRunsAtItsNiceValue) {
  // It drops scans rather than fall behind, so by default it yields the cores to queries and the exact map.
  auto o = serverOptions(155);
  o.dense.method = "bgk";
  ServiceHarness h(o);
  ASSERT_EQ(o.dense_nice, 19) << "the default";
  ASSERT_TRUE(h.robot->publish("robot-0", 0, simScans(1)[0]));
  for (int w = 0; w < 600 && h.server->denseStore()->version() < 1; ++w) std::this_thread::sleep_for(50ms);
  ASSERT_EQ(h.server->denseStore()->version(), 1u);
  const auto nice = threadNice("dm-dense");
  ASSERT_FALSE(nice.empty()) << "no thread named dm-dense";
  for (int n : nice) EXPECT_EQ(n, 19);
}

TEST(ServiceDense, WithoutADenseLayerTheDenseLayersAreUnavailable) {
  ServiceHarness h(serverOptions(151));
  msg::QueryRequest rq;
  rq.kind(msg::QUERY_POINTS);
  rq.points({1.f, 2.f, 3.f});
  rq.layer(msg::LAYER_FUSED);
  const auto r = h.query->call(rq, 30s);
  EXPECT_EQ(r.status(), msg::STATUS_LAYER_UNAVAILABLE);
  EXPECT_NE(r.message().find("--dense-layer"), std::string::npos) << r.message();
}

}  // namespace
}  // namespace densemap::test
