// How the service keeps what it acknowledged: the journal, its group commit and the snapshots.
#pragma once

#include <cstdint>
#include <string>

#include "densemap/dense/dense_layer_factory.h"
#include "densemap/map/map_factory.h"
#include "densemap/update/update_engine.h"

namespace densemap::server::durability {

struct DurabilityOptions {
  /// Journal every accepted scan and map command in DATA_DIR before acknowledging it (off: a crash loses
  /// the map since the last save, and resends are not recognised).
  bool journal = true;
  /// Group commit: one fsync for the records that arrive within this many ms of a group's first. Each
  /// record waits for it (latency) and a power cut loses no acknowledged scan; 0: one fsync per record
  /// (more fsyncs, less throughput on slow disks).
  int journal_sync_ms = 10;
  /// zstd level of records (0: uncompressed; docs/BENCHMARKS.md measures what it saves and costs).
  int journal_zstd_level = 0;
  /// A new journal segment once the current one holds this many MiB (old ones go after a snapshot).
  int journal_segment_mib = 256;
  /// Snapshot after this many journaled scans (0: not by count) ...
  std::uint64_t snapshot_every_scans = 500;
  /// ... or this many seconds after the last one with anything new (0: not by time), and on shutdown.
  double snapshot_every_s = 300.0;
  bool snapshot_on_exit = true;
  /// After each snapshot, give the freed heap back to the kernel (malloc_trim): the copy, its encoding and
  /// the dense state are tens to hundreds of MB that would otherwise stay resident as the heap's high-water
  /// mark. Costs page faults in the next copy and scans (docs/BENCHMARKS.md measures both).
  bool snapshot_returns_memory = true;
  /// Damage in the middle of the journal: refuse to start (default), or "cut" it there (keeps the valid
  /// prefix, moves the rest aside as *.damaged, and loses the records after the damage).
  std::string journal_recover = "refuse";
};

/// The settings a journal's records depend on (backend, resolution, sensor model, semantics, range, dense
/// layer). A data directory made with other settings is refused: its replay would not be exact.
std::string mapFingerprint(const map::MapOptions& map, const update::UpdateOptions& update,
                           const dense::DenseLayerOptions& dense);

}  // namespace densemap::server::durability
