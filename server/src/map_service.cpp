#include "densemap/server/map_service.h"

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
  stages.push_back(std::make_unique<OccupancyStage>(
      *store_, options_.update,
      resolveUpdatePriority(options_.update_nice, options_.update_catch_up_ms, options_.update_late_nice)));
  if (auto layer = dense::makeDenseLayer(options_.dense, options_.map.resolution)) {
    dense_store_ = std::make_unique<DenseStore>(std::move(layer));
    stages.push_back(std::make_unique<DenseStage>(*dense_store_, options_.dense_nice));
  }
  answerer_ = std::make_unique<QueryAnswerer>(*store_, options_.queries, dense_store_.get());
  pipeline_ = std::make_unique<Pipeline>(options_.pipeline, std::move(stages));
}

MapService::~MapService() { stop(); }

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

Answer MapService::answer(const Query& query) { return answerer_->answer(query); }

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
  const std::string bytes = map_dir_->read(c.name, options_.max_map_file_bytes);
  auto change = std::make_shared<MapChange>(c);
  try {
    change->loaded = map::decodeMap(bytes, options_.map);
  } catch (const map::MapFileError& e) {
    throw RequestError(Status::kInvalidArgument, c.name + ": " + e.what());
  }
  MapSummary summary = mapSummary(*change->loaded, 0);
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

ServiceStatistics MapService::statistics() const {
  ServiceStatistics s;
  s.server_id = options_.server_id;
  s.stamp_ns = util::wallClockNs();
  s.uptime_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count();
  for (auto& [id, c] : pipeline_->robotCounters()) s.robots.emplace_back(id, c);
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
  return s;
}

void MapService::stop(bool drain) {
  std::lock_guard lock(stop_mutex_);
  if (stopped_) return;
  stopped_ = true;
  spdlog::info("{}: stopping ({} queued scans {})", options_.server_id, pipeline_->inFlight(),
               drain ? "to finish" : "to drop");
  pipeline_->stop(drain);
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
