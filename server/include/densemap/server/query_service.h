// Answers map queries (the request-reply topics' payload) from a consistent state of the map: each
// answer is read under the map's shared lock and carries the map version it saw.
#pragma once

#include <atomic>
#include <cstdint>
#include <string>

#include "densemap/msg/densemap.h"
#include "densemap/server/latency_window.h"
#include "densemap/server/map_store.h"

namespace densemap::server {

struct QueryLimits {
  /// Most points in one QUERY_POINTS request.
  std::size_t max_points = 1'000'000;
  /// Cells a QUERY_BOX returns when the request's limit is 0, and the most it may ask for.
  std::uint32_t default_box_limit = 100'000;
  std::uint32_t max_box_limit = 2'000'000;
  /// Longest ray a QUERY_RAY may cast, in metres.
  double max_ray_range = 1000.0;
};

class DenseStore;

class QueryService {
 public:
  /// `dense` may be null (no dense layer: the dense and fused layers answer "unavailable").
  QueryService(MapStore& store, QueryLimits limits, DenseStore* dense = nullptr)
      : store_(store), limits_(limits), dense_(dense) {}

  /// Never throws: every problem becomes a status and a message in the reply.
  msg::QueryReply answer(const msg::QueryRequest& request);

  std::uint64_t answered() const { return answered_.load(); }
  std::uint64_t failed() const { return failed_.load(); }
  /// Time to answer (inside the server, lock waits included) of recent queries.
  LatencySummary latency() const { return latency_.summary(); }

 private:
  void denseQuery(const msg::QueryRequest& rq, msg::QueryReply& rp);
  void points(const msg::QueryRequest& rq, msg::QueryReply& rp);
  void box(const msg::QueryRequest& rq, msg::QueryReply& rp);
  void ray(const msg::QueryRequest& rq, msg::QueryReply& rp);
  void stats(msg::QueryReply& rp);
  void save(const msg::QueryRequest& rq, msg::QueryReply& rp);
  void clearBox(const msg::QueryRequest& rq, msg::QueryReply& rp);
  void reset(msg::QueryReply& rp);

  MapStore& store_;
  QueryLimits limits_;
  DenseStore* dense_;
  std::atomic<std::uint64_t> answered_{0}, failed_{0};
  LatencyWindow latency_;
};

/// Statistics of a map (iterates every cell: for queries and shutdown reports, not per scan).
msg::MapStatistics mapStatistics(const map::OccupancyMap& map, std::uint64_t version);

}  // namespace densemap::server
