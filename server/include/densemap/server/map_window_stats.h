// The map window's counters, apart from the window so the statistics can carry them.
#pragma once

#include <cstdint>

namespace densemap::server {

struct MapWindowStats {
  std::uint64_t blocks_out = 0;          ///< now out of memory (stored or dropped)
  std::uint64_t left = 0;                ///< blocks that left memory this run
  std::uint64_t came_back = 0;           ///< blocks brought back for a scan this run
  std::uint64_t dropped = 0;             ///< blocks forgotten this run (--keep-evicted-blocks false)
  std::uint64_t bytes_stored = 0;        ///< written to the block store this run
  std::uint64_t store_failures = 0;      ///< blocks kept in memory because the store could not take them
  std::uint64_t robots_forgotten = 0;    ///< robots silent past --window-robot-timeout-s this run
  std::uint64_t loaded_for_queries = 0;  ///< blocks brought back for a query this run (--window-query-load-s)
  std::uint64_t query_load_failures = 0;   ///< queries whose stored blocks could not be loaded this run
  std::uint64_t dense_blocks_dropped = 0;  ///< dense layer blocks beyond the radius dropped this run
};

}  // namespace densemap::server
