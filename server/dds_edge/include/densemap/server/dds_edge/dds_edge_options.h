// The DDS edge's options and their table (queries, statistics, clients), beside each other.
#pragma once

#include <cstddef>

#include "densemap/msg/dds_node.h"
#include "densemap/options/option_table.h"

namespace densemap::server::dds_edge {

struct DdsEdgeOptions {
  msg::DdsOptions dds{};
  /// Threads answering queries concurrently with the map update.
  int query_threads = 2;
  /// Queries waiting for a query thread at most; one more is answered STATUS_BUSY at once (and counted),
  /// so under a flood every query gets an answer in bounded time and the backlog's memory is bounded.
  std::size_t query_backlog = 64;
  /// A query with more points than this (or a box limit above it) gives its memory back to the system
  /// once answered: the allocator would otherwise keep the peak of the largest query ever asked.
  std::size_t large_query_points = 100'000;
  /// Scheduler time slice in microseconds asked for the DDS, query and other latency-bound threads (Linux
  /// >= 6.12 honours it; 0 = the kernel's default). The pipeline's stages keep the default.
  int latency_slice_us = 100;
  /// SCHED_FIFO priority (1..99) of the DDS receive threads (which answer point and ray queries) and the
  /// query threads; 0 = normal scheduling (README "Latency"). Needs root, CAP_SYS_NICE or RLIMIT_RTPRIO.
  int realtime_priority = 0;
  /// Seconds between statistics messages (and log lines); 0 disables them.
  double statistics_period_s = 1.0;
  /// At shutdown, seconds to wait until robots have confirmed the last acknowledgements (reliable DDS:
  /// deleting the writer earlier drops the ones still in flight).
  double ack_flush_s = 5.0;
  /// At start, seconds to listen for another server's statistics on the same topics before taking scans
  /// or queries: one map per namespace. A server found then (or later) that started earlier wins; this one
  /// refuses to serve (AnotherServerError, or refused() later). 0: no wait (detection continues while
  /// serving). Servers with statistics off are not seen.
  double duplicate_check_s = 1.5;
  /// Clients with a reply topic of their own at most (query and admin each); a request from one more is
  /// refused (counted) until an idle one's topic is removed.
  std::size_t max_clients = 256;
};

/// The DDS edge's own options (queries and statistics).
[[nodiscard]] options::OptionTable edgeOptions(DdsEdgeOptions& options);

}  // namespace densemap::server::dds_edge
