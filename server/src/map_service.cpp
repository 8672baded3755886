#include "densemap/server/map_service.h"

#include <cmath>
#include <filesystem>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "densemap/map/map_file.h"
#include "densemap/server/box_keys.h"
#include "densemap/server/dense_stage.h"
#include "densemap/server/densify_stage.h"
#include "densemap/server/map_change.h"
#include "densemap/server/occupancy_stage.h"
#include "densemap/server/request_error.h"
#include "densemap/server/scan_validator.h"
#include "densemap/server/service_option_table.h"
#include "densemap/server/update_priority.h"
#include "densemap/util/heap_usage.h"
#include "densemap/util/retain_freed_memory.h"
#include "densemap/util/wall_clock.h"

namespace densemap::server {

namespace {

std::filesystem::path mapDirOf(const ServiceOptions& o) {
  return o.map_dir.empty() ? std::filesystem::path(o.data_dir) / "maps" : std::filesystem::path(o.map_dir);
}

map::OctomapFormat formatOf(const std::string& name) {
  return name.ends_with(".bt") ? map::OctomapFormat::kBinary : map::OctomapFormat::kFull;
}

}  // namespace

MapService::MapService(ServiceOptions options)
    : options_(std::move(options)), started_(std::chrono::steady_clock::now()) {
  validateServiceOptions(options_);  // the option tables' ranges: the one place options are checked
  store_ = std::make_unique<MapStore>(map::makeMap(options_.map));
  map_dir_ = std::make_unique<MapDirectory>(mapDirOf(options_));
  std::vector<std::unique_ptr<PipelineStage>> stages;
  if (options_.densify.method != "none")
    stages.push_back(std::make_unique<DensifyStage>(options_.densify, makeUpsampler(options_.densify)));
  if (options_.window.enabled()) {
    std::unique_ptr<durability::BlockStore> blocks;
    if (options_.window.store)
      blocks = std::make_unique<durability::BlockStore>(std::filesystem::path(options_.data_dir) / "blocks");
    MapWindowOptions w = options_.window;
    w.snapshots = options_.durability.journal;
    window_ = std::make_unique<MapWindow>(w, std::move(blocks));
  }
  auto occupancy = std::make_unique<OccupancyStage>(
      *store_, options_.update,
      resolveUpdatePriority(options_.update_nice, options_.update_catch_up_ms, options_.update_late_nice),
      window_.get());
  occupancy_stage_ = occupancy.get();  // owned by the pipeline from here on, as long as this service
  std::unique_ptr<DenseStage> dense;
  if (auto layer = dense::makeDenseLayer(options_.dense, options_.map.resolution)) {
    dense_store_ = std::make_unique<DenseStore>(std::move(layer));
    dense = std::make_unique<DenseStage>(*dense_store_, options_.dense_nice, options_.dense_overflow,
                                         options_.window.radius_m, options_.window.robot_timeout_s);
    dense_stage_ = dense.get();  // owned by the pipeline from here on, as long as this service
  }
  if (options_.durability.journal) {
    auto journal = recoverInto(*occupancy, dense.get());
    journal_ = journal.get();
    stages.push_back(std::move(journal));
  }
  stages.push_back(std::move(occupancy));
  if (dense) stages.push_back(std::move(dense));
  answerer_ = std::make_unique<QueryAnswerer>(*store_, options_.queries, dense_store_.get());
  pipeline_ = std::make_unique<Pipeline>(options_.pipeline, std::move(stages));
  if (journal_ != nullptr) {
    last_snapshot_ = std::chrono::steady_clock::now();
    snapshot_thread_ = std::thread([this] { snapshotLoop(); });
  }
}

std::unique_ptr<durability::JournalStage> MapService::recoverInto(OccupancyStage& occupancy,
                                                                  DenseStage* dense) {
  namespace du = durability;
  // A record is at most a scan of max_points (or a loaded map file) plus its fields.
  const std::uint64_t max_record =
      std::max<std::uint64_t>(options_.limits.max_points * sizeof(geometry::Vec3f),
                              options_.max_map_file_bytes) +
      (1 << 20);
  data_dir_ = std::make_unique<du::DataDirectory>(
      options_.data_dir, du::mapFingerprint(options_.map, options_.update, options_.dense),
      options_.durability, max_record);
  du::RobotProgress progress;
  auto load = [&](const du::SnapshotContents& s) {
    store_->replace(map::decodeMap(s.map, options_.map));
    if (s.map_time_s) store_->writerView().setMapTime(*s.map_time_s);
    if (!s.window.empty()) {
      auto* grid = dynamic_cast<map::GridMap*>(&store_->writerView());
      if (!window_ || !grid)
        throw std::runtime_error(
            "the snapshot has map blocks stored out of memory; start the server with "
            "the same --window-radius / --max-map-mb settings");
      window_->restoreState(s.window, *grid);
    }
    if (dense_store_) {
      if (s.dense.empty()) throw std::runtime_error("the snapshot has no dense layer");
      dense_store_->write([&](dense::KernelLayer& layer) { layer.restoreState(s.dense); });
    }
    progress = du::RobotProgress::decode(s.progress);
  };
  std::uint64_t scans = 0, commands = 0;
  auto replay = [&](const du::RecordView& r, std::string payload) {
    const std::size_t base = r.offset + du::kRecordHeaderBytes;
    if (r.kind == du::RecordKind::kScan) {
      ScanJob job = du::decodeScanRecord(payload, base);
      progress.record(job.robot_id, job.seq);
      if (StageResult res = occupancy.replay(job); !res.ok) throw std::runtime_error(res.error);
      if (dense != nullptr) dense->replay(job);
      ++scans;
      return;
    }
    du::DecodedCommand d = du::decodeCommandRecord(r.kind, payload, base);
    MapChange change(d.command);
    if (std::holds_alternative<LoadCommand>(d.command))
      change.loaded = map::decodeMap(d.loaded_file, options_.map);
    occupancy.applyChange(change);
    if (dense != nullptr) dense->applyChange(change);
    if (change.result.status != Status::kOk) throw std::runtime_error(change.result.message);
    ++commands;
  };
  recovery_ = data_dir_->recover(load, replay);
  const auto& rep = *recovery_;
  spdlog::info(
      "{}: recovered {} from {}: {}, then {} journal records ({} scans, {} commands) in {:.2f} s; {} robots "
      "known",
      options_.server_id,
      store_->read([](const map::OccupancyMap& m, std::uint64_t) { return m.knownCells(); }),
      options_.data_dir, rep.snapshot_lsn ? "snapshot " + rep.snapshot_file : std::string("no snapshot"),
      rep.records_replayed, scans, commands, rep.seconds, progress.robots());
  auto writer = data_dir_->openWriter();
  std::uint64_t since_snapshot = rep.records_replayed;
  const std::uint64_t every = options_.durability.snapshot_every_scans;
  if (every > 0 && rep.records_replayed >= every) {
    // A snapshot at the end of recovery (as databases checkpoint after crash recovery): a server that is
    // killed again before its first periodic snapshot would otherwise replay a longer journal each time.
    try {
      const auto t0 = std::chrono::steady_clock::now();
      writer->rotate();  // the replayed records end in the old segment, which the snapshot removes
      const du::SnapshotContents s = snapshotOfLayers(writer->lastLsn(), progress.encode());
      const std::uint64_t bytes = data_dir_->writeSnapshot(s);
      if (window_) window_->snapshotWritten(s.window);
      last_snapshot_lsn_ = s.lsn;
      last_snapshot_bytes_ = bytes;
      ++snapshots_written_;
      since_snapshot = 0;
      spdlog::info("snapshot after recovery at record {} ({:.1f} MB, {:.0f} ms)", s.lsn,
                   static_cast<double>(bytes) / 1e6,
                   std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    } catch (const std::exception& e) {
      ++snapshot_failures_;
      spdlog::warn("no snapshot after recovery: {}; the next restart replays these records again", e.what());
    }
  }
  return std::make_unique<du::JournalStage>(std::move(writer), std::move(progress),
                                            options_.durability.journal_sync_ms, since_snapshot);
}

durability::SnapshotContents MapService::snapshotOfLayers(std::uint64_t lsn, std::string progress) const {
  durability::SnapshotContents s;
  s.lsn = lsn;
  s.created_ns = util::wallClockNs();
  s.fingerprint = durability::mapFingerprint(options_.map, options_.update, options_.dense);
  s.progress = std::move(progress);
  store_->read([&](const map::OccupancyMap& m, std::uint64_t) {
    s.map = map::encodeMap(m, map::OctomapFormat::kFull);
    if (!std::isnan(m.mapTime())) s.map_time_s = m.mapTime();
  });
  if (window_) s.window = window_->snapshotState();  // at start-up, before the writer thread runs
  if (dense_store_)
    s.dense = dense_store_->read([](const dense::KernelLayer& l, std::uint64_t) { return l.saveState(); });
  return s;
}

std::optional<std::uint64_t> MapService::lastDurableSeq(const std::string& robot_id) const {
  if (journal_ == nullptr) return std::nullopt;
  return journal_->lastDurableSeq(robot_id);
}

durability::RobotProgress MapService::durableProgress() const {
  return journal_ == nullptr ? durability::RobotProgress{} : journal_->durableProgress();
}

void MapService::snapshotLoop() {
  pthread_setname_np(pthread_self(), "dm-snapshot");
  const auto& d = options_.durability;
  std::unique_lock lock(snapshot_loop_mutex_);
  while (!snapshot_loop_stop_) {
    snapshot_loop_wake_.wait_for(lock, std::chrono::milliseconds(100));
    if (snapshot_loop_stop_) break;
    const std::uint64_t pending = journal_->scansSinceSnapshot();
    const double since =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - last_snapshot_).count();
    const bool by_count = d.snapshot_every_scans > 0 && pending >= d.snapshot_every_scans;
    const bool by_time = d.snapshot_every_s > 0 && pending > 0 && since >= d.snapshot_every_s;
    if (!by_count && !by_time) continue;
    lock.unlock();
    const CommandResult r = snapshot();
    if (r.status != Status::kOk) spdlog::error("snapshot failed: {}", r.message);
    lock.lock();
  }
}

CommandResult MapService::snapshot() {
  CommandResult r;
  if (journal_ == nullptr) {
    r.status = Status::kInvalidArgument;
    r.message = "snapshots need the journal (--journal true)";
    return r;
  }
  std::lock_guard one(snapshot_mutex_);
  const auto t0 = std::chrono::steady_clock::now();
  last_snapshot_ = t0;
  auto change = std::make_shared<MapChange>(SnapshotCommand{});
  r = runChange(change);
  if (r.status != Status::kOk) return r;
  snapshot_ms_.add(change->snapshot_ms);
  durability::SnapshotContents s;
  s.lsn = change->snapshot_lsn;
  s.created_ns = util::wallClockNs();
  s.fingerprint = durability::mapFingerprint(options_.map, options_.update, options_.dense);
  s.progress = std::move(change->snapshot_progress);
  s.map = map::encodeMap(*change->snapshot, map::OctomapFormat::kFull);
  if (!std::isnan(change->snapshot->mapTime())) s.map_time_s = change->snapshot->mapTime();
  s.dense = std::move(change->dense_state);
  s.window = std::move(change->window_state);
  try {
    if (window_)
      window_->syncStored(std::move(change->window_files_to_sync));  // before a snapshot names them
    last_snapshot_bytes_ = data_dir_->writeSnapshot(s);
    if (window_) window_->snapshotWritten(s.window);
  } catch (const std::exception& e) {
    ++snapshot_failures_;
    r.status = Status::kFailed;
    r.message = e.what();
    return r;
  }
  last_snapshot_lsn_ = s.lsn;
  ++snapshots_written_;
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  snapshot_write_ms_.add(ms);
  r.message = fmt::format(
      "snapshot at record {} ({} cells, {:.1f} MB) in {:.0f} ms; the copy held the update {:.1f} ms", s.lsn,
      change->snapshot->knownCells(), static_cast<double>(last_snapshot_bytes_) / 1e6, ms,
      change->snapshot_ms);
  spdlog::info("{}", r.message);
  if (options_.durability.snapshot_returns_memory) {
    // Freed now, or kept resident as the heap's high-water mark (util/retain_freed_memory.h keeps it for
    // the scans' reuse; a snapshot's buffers are far larger than a scan's).
    change.reset();
    s = {};
    util::returnFreedMemory();
  }
  return r;
}

MapService::~MapService() { stop(); }

void MapService::snapshotOnExit() {
  // The pipeline's threads are gone: the layers and the journal are read directly.
  const durability::JournalCounters j = journal_->counters();
  if (j.failed) {
    spdlog::error("no snapshot on exit: the journal failed ({}); a restart rebuilds the map from the disk",
                  j.last_error);
    return;
  }
  if (j.last_lsn == last_snapshot_lsn_ && snapshots_written_ > 0) return;
  try {
    const auto t0 = std::chrono::steady_clock::now();
    const durability::SnapshotContents s = snapshotOfLayers(j.last_lsn, journal_->durableProgress().encode());
    const std::uint64_t bytes = data_dir_->writeSnapshot(s);
    spdlog::info("snapshot on exit at record {} ({:.1f} MB, {:.0f} ms)", s.lsn,
                 static_cast<double>(bytes) / 1e6,
                 std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  } catch (const std::exception& e) {
    spdlog::error("no snapshot on exit: {}; a restart replays the journal instead", e.what());
  }
}

SubmitResult MapService::submit(ScanJob job, OutcomeCallback on_outcome) {
  if (job.received_ns == 0) job.received_ns = util::wallClockNs();
  job.on_outcome = std::move(on_outcome);
  // The map's resolution never changes (a load of another resolution is refused), so its converter is
  // read without the lock.
  const geometry::KeyConverter conv(options_.map.resolution);
  std::string why = validateScan(job, options_.limits, conv);
  if (why.empty()) {
    if (pipeline_->submit(std::move(job))) return {true, {}};  // moved from only when taken
    why = "the server is shutting down";
  }
  pipeline_->rejectAtDoor(job, why);
  return {false, why};
}

void MapService::refuse(const ScanJob& job, const std::string& why, const OutcomeCallback& on_outcome) {
  ScanJob copy;
  copy.robot_id = job.robot_id;
  copy.seq = job.seq;
  copy.publish_ns = job.publish_ns;
  copy.received_ns = job.received_ns;
  copy.on_outcome = on_outcome;
  pipeline_->rejectAtDoor(copy, why);
}

namespace {

using KeyBoxes = std::vector<std::pair<geometry::VoxelKey, geometry::VoxelKey>>;

/// The key boxes whose stored blocks an answer could not read (empty when it read everything).
KeyBoxes storedPartsOf(const Query& q, const Answer& a, const geometry::KeyConverter& conv) {
  KeyBoxes boxes;
  if (a.status != Status::kOk) return boxes;
  if (const auto* p = std::get_if<PointsAnswer>(&a.result)) {
    const auto& points = std::get<PointsQuery>(q).points;
    for (std::size_t i = 0; i < p->states.size() && i < points.size(); ++i) {
      geometry::VoxelKey k;
      if (p->states[i] == CellState::kNotInMemory && conv.toKey(points[i], k)) boxes.emplace_back(k, k);
    }
  } else if (const auto* b = std::get_if<BoxAnswer>(&a.result)) {
    const auto& box = std::get<BoxQuery>(q);
    if (b->blocks_not_in_memory > 0) boxes.push_back(boxKeys(conv, box.min, box.max));
  } else if (const auto* r = std::get_if<RayAnswer>(&a.result)) {
    geometry::VoxelKey k;
    if (r->reached_not_in_memory && conv.toKey(r->not_in_memory_at, k)) boxes.emplace_back(k, k);
  }
  return boxes;
}

}  // namespace

Answer MapService::answer(const Query& query) {
  Answer a = answerer_->answer(query);
  if (!window_ || options_.window.query_load_s <= 0.0) return a;
  // --window-query-load-s: what the answer could not read comes back (on the writer thread, in order with
  // the scans) and the query is answered again. A ray may meet one stored block after another: bounded.
  const geometry::KeyConverter conv(options_.map.resolution);
  for (int round = 0; round < kQueryLoadRounds; ++round) {
    KeyBoxes boxes = storedPartsOf(query, a, conv);
    if (boxes.empty()) break;
    const CommandResult r = runChange(std::make_shared<MapChange>(LoadStoredBlocksCommand{std::move(boxes)}));
    if (r.status != Status::kOk) {  // the answer still says what is not in memory
      ++query_loads_failed_;
      a.message += fmt::format(" (could not load the stored blocks: {})", r.message);
      break;
    }
    a = answerer_->answer(query);
  }
  return a;
}

CommandResult MapService::runChange(std::shared_ptr<MapChange> change) {
  auto done = change->done.get_future();
  if (!pipeline_->submitChange(change)) {
    CommandResult r;
    r.status = Status::kUnavailable;
    r.message = "the server is shutting down";
    return r;
  }
  done.wait();
  return std::move(change->result);
}

CommandResult MapService::save(const SaveCommand& c) {
  if (const std::string why = MapDirectory::checkName(c.name); !why.empty())
    throw RequestError(Status::kInvalidArgument, why);
  auto change = std::make_shared<MapChange>(c);
  CommandResult r = runChange(change);
  if (r.status != Status::kOk) return r;
  snapshot_ms_.add(change->snapshot_ms);
  // Encoded and written on this (the caller's) thread: the update and the readers go on meanwhile.
  map_dir_->write(c.name, map::encodeMap(*change->snapshot, formatOf(c.name)));
  r.map = mapSummary(*change->snapshot, r.map_version);
  r.message = fmt::format("saved {} ({} cells, map version {}; the snapshot held the update {:.1f} ms)",
                          c.name, r.map->known_cells, r.map_version, change->snapshot_ms);
  return r;
}

CommandResult MapService::load(const LoadCommand& c) {
  if (const std::string why = MapDirectory::checkName(c.name); !why.empty())
    throw RequestError(Status::kInvalidArgument, why);
  std::string bytes = map_dir_->read(c.name, options_.max_map_file_bytes);
  auto change = std::make_shared<MapChange>(c);
  try {
    change->loaded = map::decodeMap(bytes, options_.map);
  } catch (const map::MapFileError& e) {
    throw RequestError(Status::kInvalidArgument, c.name + ": " + e.what());
  }
  MapSummary summary = mapSummary(*change->loaded, 0);
  if (journal_ != nullptr) change->loaded_file = std::move(bytes);  // the journal keeps the file
  CommandResult r = runChange(change);
  if (r.status != Status::kOk) return r;
  summary.map_version = r.map_version;
  r.map = summary;
  r.message = fmt::format("loaded {}: {} cells{}", c.name, summary.known_cells,
                          dense_store_ ? " (the dense layer starts over)" : "");
  return r;
}

CommandResult MapService::execute(const Command& command, const std::string& requester) {
  CommandResult r;
  reportingErrors(r, [&] {
    if (const auto* s = std::get_if<SaveCommand>(&command)) {
      r = save(*s);
    } else if (const auto* l = std::get_if<LoadCommand>(&command)) {
      r = load(*l);
    } else if (std::holds_alternative<SnapshotCommand>(command)) {
      r = snapshot();
    } else {
      if (const auto* b = std::get_if<ClearBoxCommand>(&command))
        boxKeys(geometry::KeyConverter(options_.map.resolution), b->min, b->max);  // a clear error now
      r = runChange(std::make_shared<MapChange>(command));
    }
  });
  const std::string who = requester.empty() ? "an unnamed client" : requester;
  if (r.status == Status::kOk) {
    ++commands_done_;
    spdlog::info("{} by {}: {}", commandName(command), who, r.message);
  } else {
    ++commands_failed_;
    spdlog::warn("{} by {} refused ({}): {}", commandName(command), who, toString(r.status), r.message);
  }
  return r;
}

std::optional<MapWindow::Stats> MapService::windowStats() const {
  if (!window_) return std::nullopt;
  MapWindow::Stats s = window_->stats();
  s.query_load_failures = query_loads_failed_.load();
  if (dense_stage_ != nullptr) s.dense_blocks_dropped = dense_stage_->blocksDropped();
  return s;
}

ServiceStatistics MapService::statistics() const {
  ServiceStatistics s;
  s.update_method = update::toString(options_.update.method);
  if (occupancy_stage_ != nullptr) {
    const auto scans = occupancy_stage_->methodScans();
    for (std::size_t i = 0; i < scans.size(); ++i)
      s.update_methods.emplace_back(update::toString(update::kAllMethods[i]), scans[i]);
  }
  s.server_id = options_.server_id;
  s.stamp_ns = util::wallClockNs();
  s.uptime_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count();
  auto robots = pipeline_->robotCounters();
  if (journal_ != nullptr) {
    journal_->durableProgress().forEachRobot(
        [&](const std::string& id, std::uint64_t count, std::uint64_t records, std::uint64_t last) {
          RobotCounters& c = robots[id];  // robots known from earlier runs are listed too
          c.durable_scans = count;
          c.journaled_scans = records;
          c.last_durable_seq = last;
        });
    auto& d = s.durability;
    const durability::JournalCounters j = journal_->counters();
    d.enabled = true;
    d.records = j.records;
    d.bytes = j.bytes;
    d.syncs = j.syncs;
    d.duplicates = j.duplicates;
    d.failures = j.failures;
    d.failed = j.failed;
    d.last_error = j.last_error;
    d.last_lsn = j.last_lsn;
    d.sync_ms = j.sync_ms;
    d.snapshots = snapshots_written_;
    d.snapshot_failures = snapshot_failures_;
    d.snapshot_lsn = last_snapshot_lsn_;
    d.snapshot_bytes = last_snapshot_bytes_;
    d.snapshot_ms = snapshot_write_ms_.summary();
    if (recovery_) {
      d.recovered_records = recovery_->records_replayed;
      d.recovery_s = recovery_->seconds;
    }
  }
  for (auto& [id, c] : robots) s.robots.emplace_back(id, c);
  s.window = windowStats();
  s.stages = pipeline_->stageCounters();
  auto pseudoStage = [&](const char* name, std::uint64_t processed, const LatencySummary& l) {
    StageCounters st;
    st.name = name;
    st.processed = processed;
    st.latency = l;
    s.stages.push_back(std::move(st));
  };
  pseudoStage("queries", answerer_->answered() + answerer_->failed(), answerer_->latency());
  const LatencySummary hold = store_->exclusiveHold(), wait = store_->readWait(),
                       snapshot = snapshot_ms_.summary();
  pseudoStage("map-publish", hold.count, hold);  // count: samples in the latency window
  pseudoStage("map-read-wait", wait.count, wait);
  if (snapshot.count > 0) pseudoStage("map-snapshot", snapshot.count, snapshot);
  store_->read([&](const map::OccupancyMap& m, std::uint64_t version) {
    s.backend = m.backendName();
    s.resolution = m.resolution();
    s.map_version = version;
    s.memory_bytes = m.memoryBytes();
    return 0;
  });
  s.publish_to_map = pipeline_->publishToMapLatency();
  s.queries_answered = answerer_->answered();
  s.queries_failed = answerer_->failed();
  s.queries_busy = answerer_->busy();
  s.commands_done = commands_done_;
  s.commands_failed = commands_failed_;
  s.resident_bytes = residentBytes();
  const util::HeapUsage heap = util::heapUsage();
  s.heap_in_use_bytes = heap.in_use_bytes;
  s.heap_free_bytes = heap.free_bytes;
  return s;
}

void MapService::stop(bool drain) {
  std::lock_guard lock(stop_mutex_);
  if (stopped_) return;
  stopped_ = true;
  spdlog::info("{}: stopping ({} queued scans {})", options_.server_id, pipeline_->inFlight(),
               drain ? "to finish" : "to drop");
  if (snapshot_thread_.joinable()) {
    {
      std::lock_guard lock(snapshot_loop_mutex_);
      snapshot_loop_stop_ = true;
    }
    snapshot_loop_wake_.notify_all();
    snapshot_thread_.join();
  }
  pipeline_->stop(drain);
  if (journal_ != nullptr && options_.durability.snapshot_on_exit) snapshotOnExit();
  if (!options_.save_on_exit.empty()) {
    try {
      store_->read([&](const map::OccupancyMap& m, std::uint64_t) {
        map::saveMap(m, options_.save_on_exit);
        return 0;
      });
      spdlog::info("saved the map to {}", options_.save_on_exit);
    } catch (const std::exception& e) {
      spdlog::error("could not save the map on exit: {}", e.what());
    }
  }
}

}  // namespace densemap::server
