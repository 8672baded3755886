#include "densemap/server/service_option_table.h"

#include "densemap/dense/dense_option_table.h"
#include "densemap/map/map_option_table.h"
#include "densemap/update/update_option_table.h"

namespace densemap::server {

std::vector<options::OptionTable> serviceOptionTables(ServiceOptions& o) {
  std::vector<options::OptionTable> tables;
  {
    options::OptionTable& t = tables.emplace_back("Server");
    t.add("server-id", o.server_id, "name in statistics and logs");
  }
  {
    options::OptionTable& t = tables.emplace_back(
        "Densify (Ch. 4), a stage before the map: sparse scans re-sampled to a denser beam layout");
    t.add("densify", o.densify.method, "none, iln (trained network; loads its plugin) or bilinear")
        .oneOf({"none", "iln", "bilinear"});
    t.add("densify-weights", o.densify.weights, "ILN weights (empty: the shipped models/iln/iln_compact.pt)");
    t.add("densify-input-rows", o.densify.input_rows,
          "densify scans from LiDARs with this many beams (0: any scan carrying its geometry)")
        .range(0, 1024);
    t.add("densify-robots", o.densify.robots, "or densify exactly these robots' scans");
    t.add("densify-rows", o.densify.target_rows, "beams after densifying (every input beam is kept)")
        .range(1, 1024);
    t.add("densify-columns", o.densify.target_columns, "columns after densifying (0: the input's)")
        .range(0, 16384);
    t.add("densify-threads", o.densify.threads, "threads of the densify network").range(1, 64);
  }
  {
    options::OptionTable& t = tables.emplace_back(
        "Dense layer (Ch. 3), a stage after the exact map; it drops the oldest scans when behind");
    t.add("dense-layer", o.dense.method, "none, akimap or bgk").oneOf({"none", "akimap", "bgk"});
    t.add("dense-resolution", o.dense.resolution, "cell size in metres (0: the map's resolution)")
        .range(0.0, 100.0);
    t.add("dense-max-range", o.dense.max_range, "cut rays here for the dense layer (metres; < 0: unlimited)")
        .range(-1.0, 1e5);
    t.addChoice(
        "dense-overflow", o.dense_overflow,
        {{"drop_oldest", OverflowPolicy::kDropOldest}, {"wait", OverflowPolicy::kWait}},
        "when it falls behind: drop_oldest (the exact map never waits) or wait (it takes every scan, so "
        "its layer is that of every acknowledged scan, also after a restart)");
    t.add("dense-nice", o.dense_nice, "nice value of its threads: it drops scans rather than fall behind")
        .range(0, 19);
  }
  tables.push_back(dense::kernelLayerOptionTable(o.dense));
  {
    options::OptionTable& t = tables.emplace_back(
        "Map memory (grid backend): a rolling window and a cap; blocks that leave come back when a scan "
        "reaches them");
    t.add("window-radius", o.window.radius_m,
          "map blocks farther than this (metres) from every robot's latest sensor position leave memory "
          "after each scan (0: off); make it at least the sensor's range, or blocks come and go every scan")
        .range(0.0, 1e6);
    t.add("max-map-mb", o.window.max_map_mb,
          "when the exact map's memory passes this many MB, the least recently updated blocks leave it, "
          "down to 90% (0: no cap)")
        .range(0.0, 1e7);
    t.add("window-robot-timeout-s", o.window.robot_timeout_s,
          "a robot whose latest scan is this many seconds old (map time: the scans' receive time) no longer "
          "keeps the blocks around it in memory (0: robots are never forgotten)")
        .range(0.0, 1e9);
    t.add("window-query-load-s", o.window.query_load_s,
          "a query that reaches blocks stored out of memory loads them (waiting for the map's writer) and "
          "they stay in memory this many seconds of map time; 0: the answer says they are not in memory")
        .range(0.0, 1e9);
    t.add("keep-evicted-blocks", o.window.store,
          "true: blocks that leave memory are kept in DATA_DIR/blocks and load again when a scan reaches "
          "them (the map stays the map of every scan); false: they are forgotten")
        .checkedBy([&o] {
          if (o.window.enabled() && o.map.backend != "grid")
            return std::string("--window-radius and --max-map-mb need --backend grid");
          return std::string();
        });
  }
  {
    options::OptionTable& t = tables.emplace_back("Pipeline");
    t.add("robot-queue", o.pipeline.robot_queue_capacity, "scans each robot may have waiting")
        .range(1, 100000);
    t.addChoice(
        "overflow", o.pipeline.overflow,
        {{"wait", OverflowPolicy::kWait}, {"drop_oldest", OverflowPolicy::kDropOldest}},
        "a robot's queue is full: wait (back-pressure, nothing lost) or drop_oldest (bounded latency, "
        "counted)");
    t.add("max-robots", o.pipeline.max_robots,
          "robots served at most (and robots with scan and acknowledgement topics of their own, "
          "densemap/scans/<robot_id>)")
        .range(1, 100000);
    t.add("max-points", o.limits.max_points, "larger scans are rejected").range(1, 1e8);
    t.add("update-threads", o.update_threads, "threads of the map update (0: all cores)").range(0, 1024);
    t.add("update-idle-spin", o.update_idle_spin,
          "times an idle OpenMP worker of the update spins before it sleeps (GOMP_SPINCOUNT; -1: libgomp's "
          "default); spinning idle workers take CPU from the other robots' scans")
        .range(-1, 2e9);
    t.add("update-nice", o.update_nice,
          "nice value of the map update while scans are on time (-1: 19 if the server may raise it back "
          "when a scan is late, else 0)")
        .range(-1, 19);
    t.add("update-catch-up-ms", o.update_catch_up_ms,
          "a scan this late is updated at normal priority (queries cannot starve the map)")
        .range(0, 1e6);
    t.add("update-late-nice", o.update_late_nice,
          "nice value of a late scan's update (below 0: less map lag under query floods; needs CAP_SYS_NICE)")
        .range(-20, 0);
  }
  {
    options::OptionTable& t =
        tables.emplace_back("Storage: save and load requests name files in the map directory, never paths");
    t.add("data-dir", o.data_dir, "the service's data directory");
    t.add("map-dir", o.map_dir, "where saves and loads go (empty: DATA_DIR/maps)");
    t.add("max-map-file-bytes", o.max_map_file_bytes, "largest map file a load reads").range(1, 1e12);
  }
  {
    auto& d = o.durability;
    options::OptionTable& t = tables.emplace_back(
        "Durability: the journal and snapshots in DATA_DIR; an acknowledged scan survives a crash, kill -9 "
        "or power cut (docs/DURABILITY.md)");
    t.add("journal", d.journal,
          "journal every scan and map command before acknowledging it (false: a crash loses the map)");
    t.add("journal-sync-ms", d.journal_sync_ms,
          "group commit: one fsync for the records of this many ms (each waits up to that long for its ack; "
          "0: one fsync per record, slower on slow disks)")
        .range(0, 1000);
    t.add("journal-zstd", d.journal_zstd_level, "zstd level of journal records (0: uncompressed)")
        .range(0, 19);
    t.add("journal-segment-mib", d.journal_segment_mib, "start a new journal file after this many MiB")
        .range(1, 65536);
    t.add("journal-recover", d.journal_recover,
          "damage in the middle of the journal: refuse to start, or cut it there (loses what follows)")
        .oneOf({"refuse", "cut"});
    t.add("snapshot-every-scans", d.snapshot_every_scans,
          "snapshot after this many journaled scans (0: not by count); the journal behind it is removed")
        .range(0, 1e9);
    t.add("snapshot-every-s", d.snapshot_every_s, "or this many seconds after the last one (0: not by time)")
        .range(0.0, 1e7);
    t.add("snapshot-on-exit", d.snapshot_on_exit, "snapshot on shutdown (a restart then replays nothing)");
    t.add("snapshot-returns-memory", d.snapshot_returns_memory,
          "after each snapshot give the heap it freed back to the kernel (lower resident memory; the next "
          "snapshot's copy and scans fault their pages in again)");
  }
  {
    options::OptionTable& t = tables.emplace_back("Shutdown (SIGINT / SIGTERM)");
    t.add("save-on-exit", o.save_on_exit,
          "save the map to this path (.bt or .ot) on shutdown (empty: do not)");
    t.add("drop-on-exit", o.drop_on_exit, "drop queued scans (counted) instead of mapping them first");
  }
  return tables;
}

void validateServiceOptions(const ServiceOptions& options) {
  ServiceOptions copy = options;  // the tables bind to fields; nothing is changed
  std::vector<options::OptionTable> tables = serviceOptionTables(copy);
  tables.push_back(map::mapOptionTable(copy.map));
  tables.push_back(update::updateOptionTable(copy.update));
  for (const options::OptionTable& t : tables) {
    if (const std::string why = t.validate(); !why.empty()) throw std::invalid_argument(why);
  }
}

}  // namespace densemap::server
