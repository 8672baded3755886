// Answers map queries from a consistent state of the map: each answer is read under the layer's shared
// lock and carries the map version it saw.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>

#include "densemap/server/latency_window.h"
#include "densemap/server/map_stores.h"
#include "densemap/server/query.h"
#include "densemap/server/stage_options.h"

namespace densemap::server {

class QueryAnswerer {
 public:
  /// `dense` may be null (no dense layer: the dense and fused layers answer kLayerUnavailable).
  QueryAnswerer(const MapStore& store, QueryLimits limits, const DenseStore* dense = nullptr)
      : store_(store), limits_(limits), dense_(dense) {}

  /// Never throws: every problem becomes a status and a message.
  Answer answer(const Query& query);

  std::uint64_t answered() const { return answered_.load(); }
  std::uint64_t failed() const { return failed_.load(); }
  void countFailure() { ++failed_; }
  std::uint64_t busy() const { return busy_.load(); }
  void countBusy() { ++busy_; }
  /// Time to answer (lock waits included) of recent queries.
  LatencySummary latency() const { return latency_.summary(); }

 private:
  void dense(const Query& q, Answer& a);
  void points(const PointsQuery& q, Answer& a);
  void box(const BoxQuery& q, Answer& a);
  void ray(const RayQuery& q, Answer& a);
  void stats(Answer& a);

  const MapStore& store_;
  QueryLimits limits_;
  const DenseStore* dense_;
  std::atomic<std::uint64_t> answered_{0}, failed_{0}, busy_{0};
  LatencyWindow latency_;
};

/// A map's figures (iterates every cell: for queries, saves and shutdown reports, not per scan).
MapSummary mapSummary(const map::OccupancyMap& map, std::uint64_t version);

}  // namespace densemap::server
