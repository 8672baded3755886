// Helpers of the MapService tests: outcomes heard through the submit callback, scans as an edge hands
// them over, and the offline map of scans as the service rebuilds them.
#pragma once

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include "densemap/io/lidar_simulator.h"
#include "densemap/map/map_factory.h"

#include "densemap/server/map_service.h"
#include "densemap/server/scan_job.h"
#include "densemap/update/update_engine.h"
#include "test_simulator.h"

namespace densemap::test {

using namespace std::chrono_literals;

/// Outcomes heard through the submit callback, waited for by count.
class Outcomes {
 public:
  server::OutcomeCallback callback() {
    return [this](const server::ScanJob& j, server::ScanOutcome o, const std::string& why) {
      std::lock_guard lock(mutex_);
      seen_.push_back({j.seq, o, why});
      changed_.notify_all();
    };
  }
  bool waitFor(std::size_t n, std::chrono::seconds timeout = 120s) {
    std::unique_lock lock(mutex_);
    return changed_.wait_for(lock, timeout, [&] { return seen_.size() >= n; });
  }
  std::size_t count(server::ScanOutcome o) {
    std::lock_guard lock(mutex_);
    return static_cast<std::size_t>(
        std::count_if(seen_.begin(), seen_.end(), [&](const auto& s) { return s.outcome == o; }));
  }
  std::string lastWhy() {
    std::lock_guard lock(mutex_);
    return seen_.empty() ? "" : seen_.back().why;
  }

 private:
  struct Seen {
    std::uint64_t seq;
    server::ScanOutcome outcome;
    std::string why;
  };
  std::mutex mutex_;
  std::condition_variable changed_;
  std::vector<Seen> seen_;
};

inline server::ScanJob jobOf(const io::Scan& s, const std::string& robot, std::uint64_t seq) {
  server::ScanJob j;
  j.robot_id = robot;
  j.seq = seq;
  const Eigen::Vector3d t = s.pose.translation();
  j.position = {t.x(), t.y(), t.z()};
  j.quaternion = io::quaternionOf(s.pose);
  j.scan.points = s.sensorPoints();
  j.scan.frame = io::PointFrame::kSensor;
  j.scan.lidar = s.lidar;
  return j;
}

inline std::vector<io::Scan> simScans(int n) {
  io::LidarSimulator sim(smallSimulator(n));
  std::vector<io::Scan> out;
  for (int i = 0; i < n; ++i) out.push_back(sim.read(static_cast<std::size_t>(i)));
  return out;
}

/// The offline map of the scans as the service rebuilds them (pose through position + quaternion).
inline std::unique_ptr<map::OccupancyMap> offline(const std::vector<io::Scan>& scans,
                                                  const map::MapOptions& o) {
  auto m = map::makeMap(o);
  update::UpdateEngine engine;
  for (const io::Scan& s : scans) {
    io::Scan sent = s;
    const server::ScanJob j = jobOf(s, "x", 0);
    sent.pose = io::poseFromQuaternion(j.position, j.quaternion);
    engine.insert(*m, sent.worldPoints(), sent.origin());
  }
  return m;
}

/// Every cell of `expected` is answered with its probability and state, and the map knows no other cell.
inline void expectAnswers(server::MapService& service, const map::OccupancyMap& expected) {
  const server::Answer stats = service.answer(server::StatsQuery{});
  ASSERT_EQ(stats.status, server::Status::kOk) << stats.message;
  EXPECT_EQ(std::get<server::MapSummary>(stats.result).known_cells, expected.knownCells());
  std::vector<geometry::Vec3f> points;
  std::vector<float> want;
  expected.forEachCell([&](const geometry::VoxelKey& k, float v) {
    points.push_back(expected.converter().toCoord(k));
    want.push_back(map::OccupancyParams::probability(v));
  });
  std::size_t wrong = 0;
  constexpr std::size_t kChunk = 200'000;  // under the service's per-query limit
  for (std::size_t begin = 0; begin < points.size(); begin += kChunk) {
    const std::size_t end = std::min(points.size(), begin + kChunk);
    server::PointsQuery q{{points.begin() + static_cast<std::ptrdiff_t>(begin),
                           points.begin() + static_cast<std::ptrdiff_t>(end)},
                          server::Layer::kOccupancy};
    const server::Answer a = service.answer(q);
    ASSERT_EQ(a.status, server::Status::kOk) << a.message;
    const auto& p = std::get<server::PointsAnswer>(a.result);
    ASSERT_EQ(p.probabilities.size(), end - begin);
    for (std::size_t i = begin; i < end; ++i)
      wrong += p.probabilities[i - begin] != want[i] || p.states[i - begin] == server::CellState::kUnknown;
  }
  EXPECT_EQ(wrong, 0u) << "of " << want.size() << " cells";
}

}  // namespace densemap::test
