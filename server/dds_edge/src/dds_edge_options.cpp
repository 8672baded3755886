#include "densemap/server/dds_edge/dds_edge_options.h"

namespace densemap::server::dds_edge {

options::OptionTable edgeOptions(DdsEdgeOptions& o) {
  options::OptionTable t("Queries and statistics (the DDS edge)");
  t.add("query-threads", o.query_threads, "threads answering queries concurrently with the map update")
      .range(1, 64);
  t.add("query-backlog", o.query_backlog,
        "queries waiting for a query thread at most; further ones are answered busy at once")
      .range(1, 1e6);
  t.add("large-query-points", o.large_query_points,
        "queries with more points (or a larger box limit) give their memory back once answered")
      .range(1, 1e9);
  t.add("latency-slice-us", o.latency_slice_us,
        "scheduler slice of the DDS and query threads in microseconds (Linux >= 6.12; 0: the kernel's)")
      .range(0, 1e6);
  t.add(
       "realtime-priority", o.realtime_priority,
       "SCHED_FIFO priority of the DDS and query threads (needs CAP_SYS_NICE or `ulimit -r`; 0: off; README)")
      .range(0, 99);
  t.add("statistics-period", o.statistics_period_s,
        "seconds between statistics messages and log lines (0: off)")
      .range(0.0, 3600.0);
  t.add(
       "duplicate-check", o.duplicate_check_s,
       "at start, seconds to listen for another server on the same topics before serving (one per namespace)")
      .range(0.0, 60.0);
  t.add(
       "max-clients", o.max_clients,
       "query (and admin) clients with a reply topic of their own at most; one more is refused until an idle "
       "one's topic is removed")
      .range(1, 100000);
  t.add("ack-flush", o.ack_flush_s,
        "at shutdown, seconds to wait until robots confirm the last scan acknowledgements")
      .range(0.0, 600.0);
  return t;
}

}  // namespace densemap::server::dds_edge
