#include "densemap/server/dds_edge/wire.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "densemap/msg/checked_type.h"
#include "densemap/util/wall_clock.h"

namespace densemap::server::dds_edge {

namespace {

Vec3f vec(const std::array<float, 3>& a) { return {a[0], a[1], a[2]}; }
std::array<float, 3> arr(const Vec3f& v) { return {v.x(), v.y(), v.z()}; }

std::optional<Layer> layerOf(msg::MapLayer l) {
  switch (l) {
    case msg::LAYER_OCCUPANCY:
      return Layer::kOccupancy;
    case msg::LAYER_DENSE:
      return Layer::kDense;
    case msg::LAYER_FUSED:
      return Layer::kFused;
  }
  return std::nullopt;
}

Answer failure(Status s, std::string why) {
  Answer a;
  a.status = s;
  a.message = std::move(why);
  return a;
}

}  // namespace

ScanJob toScanJob(const msg::Scan& m, std::string& why) {
  ScanJob job;
  job.robot_id = m.robot_id();
  job.seq = m.seq();
  job.publish_ns = m.publish_ns();
  job.position = {m.sensor_pose().px(), m.sensor_pose().py(), m.sensor_pose().pz()};
  job.quaternion = {m.sensor_pose().qw(), m.sensor_pose().qx(), m.sensor_pose().qy(), m.sensor_pose().qz()};
  job.scan.index = m.seq();
  const std::string& frame = m.frame_id();
  job.scan.frame = (frame == "world" || frame == "map") ? io::PointFrame::kWorld : io::PointFrame::kSensor;
  const auto& xyz = m.points();
  if (xyz.size() % 3 != 0) {
    why = "points must be packed x y z (got a length not divisible by 3)";
  } else {
    job.scan.points.resize(xyz.size() / 3);
    for (std::size_t i = 0; i < job.scan.points.size(); ++i)
      job.scan.points[i] = geometry::Vec3f(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);
  }
  const auto& g = m.lidar();
  if (g.rows() > 0 && g.columns() > 0) {
    job.scan.lidar =
        io::LidarGeometry{g.rows(), g.columns(), g.fov_up_deg(), g.fov_down_deg(), g.fov_horizontal_deg()};
  }
  return job;
}

msg::ScanAck toAck(const ScanJob& job, ScanOutcome outcome, const std::string& why) {
  msg::ScanAck ack;
  ack.robot_id(job.robot_id);
  ack.seq(job.seq);
  ack.outcome(outcome == ScanOutcome::kInMap       ? msg::SCAN_APPLIED
              : outcome == ScanOutcome::kDropped   ? msg::SCAN_DROPPED
              : outcome == ScanOutcome::kDuplicate ? msg::SCAN_DUPLICATE
                                                   : msg::SCAN_REJECTED);
  ack.durable(job.durable && (outcome == ScanOutcome::kInMap || outcome == ScanOutcome::kDuplicate));
  ack.message(why);
  ack.publish_ns(job.publish_ns);
  ack.done_ns(outcome == ScanOutcome::kInMap ? job.in_map_ns : util::wallClockNs());
  const auto n = static_cast<std::uint32_t>(job.scan.points.size());
  ack.points_used(n - std::min(job.points_rejected, n));
  ack.points_rejected(job.points_rejected);
  ack.map_version(job.map_version);
  return ack;
}

std::variant<Query, Answer> toQuery(const msg::QueryRequest& rq) {
  const auto layer = layerOf(rq.layer());
  if (!layer)
    return failure(Status::kInvalidArgument, fmt::format("unknown layer {} (occupancy 0, dense 1, fused 2)",
                                                         static_cast<unsigned>(rq.layer())));
  switch (rq.kind()) {
    case msg::QUERY_POINTS: {
      const auto& xyz = rq.points();
      if (xyz.size() % 3 != 0)
        return failure(Status::kInvalidArgument, "points must be packed x y z (a multiple of 3 floats)");
      PointsQuery q;
      q.layer = *layer;
      q.points.resize(xyz.size() / 3);
      for (std::size_t i = 0; i < q.points.size(); ++i)
        q.points[i] = Vec3f(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);
      return q;
    }
    case msg::QUERY_BOX:
      return BoxQuery{vec(rq.box_min()), vec(rq.box_max()), rq.limit(), *layer};
    case msg::QUERY_RAY:
      return RayQuery{vec(rq.ray_origin()), vec(rq.ray_direction()), rq.max_range(), rq.ignore_unknown(),
                      *layer};
    case msg::QUERY_STATS:
      return StatsQuery{};
  }
  return failure(Status::kUnknownKind,
                 fmt::format("unknown query kind {}; this server knows kinds 0..{} (commands such as save "
                             "and reset go to the admin topic)",
                             static_cast<unsigned>(rq.kind()), static_cast<unsigned>(msg::QUERY_STATS)));
}

msg::QueryStatus toWire(Status s) {
  switch (s) {
    case Status::kOk:
      return msg::STATUS_OK;
    case Status::kInvalidArgument:
      return msg::STATUS_INVALID_ARGUMENT;
    case Status::kUnknownKind:
      return msg::STATUS_UNKNOWN_KIND;
    case Status::kLayerUnavailable:
      return msg::STATUS_LAYER_UNAVAILABLE;
    case Status::kFailed:
      return msg::STATUS_FAILED;
    case Status::kNotFound:
      return msg::STATUS_NOT_FOUND;
    case Status::kUnavailable:
      return msg::STATUS_UNAVAILABLE;
    case Status::kBusy:
      return msg::STATUS_BUSY;
  }
  return msg::STATUS_FAILED;
}

msg::MapStatistics toWire(const MapSummary& s) {
  msg::MapStatistics m;
  m.backend(s.backend);
  m.resolution(s.resolution);
  m.map_version(s.map_version);
  m.known_cells(s.known_cells);
  m.occupied_cells(s.occupied_cells);
  m.memory_bytes(s.memory_bytes);
  m.bounds_min(arr(s.bounds_min));
  m.bounds_max(arr(s.bounds_max));
  return m;
}

msg::QueryReply toReply(const msg::QueryRequest& rq, Answer a) {
  msg::QueryReply rp;
  rp.client_id(rq.client_id());
  rp.request_id(rq.request_id());
  rp.kind(rq.kind());
  rp.status(toWire(a.status));
  rp.message(std::move(a.message));
  rp.map_version(a.map_version);
  if (auto* p = std::get_if<PointsAnswer>(&a.result)) {
    rp.probabilities(std::move(p->probabilities));
    rp.states().resize(p->states.size());
    std::transform(p->states.begin(), p->states.end(), rp.states().begin(), [](CellState c) {
      return c == CellState::kOccupied      ? msg::CELL_OCCUPIED
             : c == CellState::kFree        ? msg::CELL_FREE
             : c == CellState::kNotInMemory ? msg::CELL_NOT_IN_MEMORY
                                            : msg::CELL_UNKNOWN;
    });
  } else if (const auto* b = std::get_if<BoxAnswer>(&a.result)) {
    rp.cells().reserve(3 * b->cells.size());
    for (const Vec3f& c : b->cells) rp.cells().insert(rp.cells().end(), {c.x(), c.y(), c.z()});
    rp.truncated(b->truncated);
    rp.blocks_not_in_memory(b->blocks_not_in_memory);
  } else if (const auto* r = std::get_if<RayAnswer>(&a.result)) {
    rp.hit(r->hit);
    rp.hit_point(arr(r->hit_point));
    rp.ray_reached_not_in_memory(r->reached_not_in_memory);
  } else if (const auto* s = std::get_if<MapSummary>(&a.result)) {
    rp.stats(toWire(*s));
  }
  return rp;
}

std::variant<std::monostate, Command, CommandResult> toCommand(const msg::AdminRequest& rq) {
  switch (rq.kind()) {
    case msg::ADMIN_PING:
      return std::monostate{};
    case msg::ADMIN_SAVE:
      return Command{SaveCommand{rq.name()}};
    case msg::ADMIN_LOAD:
      return Command{LoadCommand{rq.name()}};
    case msg::ADMIN_CLEAR_BOX:
      return Command{ClearBoxCommand{vec(rq.box_min()), vec(rq.box_max())}};
    case msg::ADMIN_RESET:
      return Command{ResetCommand{}};
  }
  CommandResult r;
  r.status = Status::kUnknownKind;
  r.message = fmt::format("unknown command kind {}; this server knows kinds 0..{}",
                          static_cast<unsigned>(rq.kind()), static_cast<unsigned>(msg::ADMIN_RESET));
  return r;
}

msg::AdminReply toReply(const msg::AdminRequest& rq, const CommandResult& r) {
  msg::AdminReply rp;
  rp.client_id(rq.client_id());
  rp.request_id(rq.request_id());
  rp.kind(rq.kind());
  rp.status(toWire(r.status));
  rp.message(r.message);
  rp.map_version(r.map_version);
  rp.cells_changed(r.cells_changed);
  if (r.map) rp.stats(toWire(*r.map));
  return rp;
}

std::optional<std::int64_t> serverStartNs(const msg::ServerStatistics& m) {
  const double uptime_s = m.uptime_s();
  // A century of uptime and stamps up to 2^62 ns (year 2116) keep the arithmetic inside int64.
  if (!std::isfinite(uptime_s) || uptime_s < 0.0 || uptime_s > 3.2e9) return std::nullopt;
  if (m.stamp_ns() <= 0 || m.stamp_ns() > (std::int64_t{1} << 62)) return std::nullopt;
  return m.stamp_ns() - static_cast<std::int64_t>(uptime_s * 1e9);
}

msg::ServerStatistics toWire(const ServiceStatistics& s) {
  msg::ServerStatistics m;
  m.server_id(s.server_id);
  m.stamp_ns(s.stamp_ns);
  m.uptime_s(s.uptime_s);
  for (const auto& [id, c] : s.robots) {
    msg::RobotStatistics r;
    r.robot_id(id);
    r.received(c.received);
    r.processed(c.processed);
    r.dropped(c.dropped);
    r.rejected(c.rejected);
    r.points_rejected(c.points_rejected);
    r.queue_depth(static_cast<std::uint32_t>(c.queue_depth));
    r.queue_capacity(static_cast<std::uint32_t>(c.queue_capacity));
    r.last_sequence(c.last_seq);
    r.duplicates(c.duplicates);
    r.durable_scans(c.durable_scans);
    r.journaled_scans(c.journaled_scans);
    r.last_durable_sequence(c.last_durable_seq);
    m.robots().push_back(std::move(r));
  }
  for (const StageCounters& c : s.stages) {
    msg::StageStatistics st;
    st.name(c.name);
    st.processed(c.processed);
    st.dropped(c.dropped);
    st.queue_depth(static_cast<std::uint32_t>(c.queue_depth));
    st.latency_p50_ms(c.latency.p50_ms);
    st.latency_p99_ms(c.latency.p99_ms);
    st.latency_max_ms(c.latency.max_ms);
    m.stages().push_back(std::move(st));
  }
  m.update_method(s.update_method);
  for (const auto& [method, scans] : s.update_methods) {
    msg::UpdateMethodCount c;
    c.method(method);
    c.scans(scans);
    m.update_methods().push_back(std::move(c));
  }
  m.map_stats().backend(s.backend);
  m.map_stats().resolution(s.resolution);
  m.map_stats().map_version(s.map_version);
  m.map_stats().memory_bytes(s.memory_bytes);
  m.publish_to_map_p50_ms(s.publish_to_map.p50_ms);
  m.publish_to_map_p99_ms(s.publish_to_map.p99_ms);
  m.queries_answered(s.queries_answered);
  m.queries_failed(s.queries_failed);
  m.queries_busy(s.queries_busy);
  m.commands_done(s.commands_done);
  m.commands_failed(s.commands_failed);
  m.resident_bytes(s.resident_bytes);
  m.heap_in_use_bytes(s.heap_in_use_bytes);
  m.heap_free_bytes(s.heap_free_bytes);
  m.samples_undecodable(msg::undecodableSamples());
  m.journal(s.durability.enabled);
  m.journal_failed(s.durability.failed);
  m.journal_bytes(s.durability.bytes);
  m.journal_syncs(s.durability.syncs);
  m.journal_failures(s.durability.failures);
  m.snapshots(s.durability.snapshots);
  m.recovered_records(s.durability.recovered_records);  // counted by the edge's readers, not the service
  if (s.window) {
    m.window().enabled(true);
    m.window().blocks_out_of_memory(s.window->blocks_out);
    m.window().blocks_evicted(s.window->left);
    m.window().blocks_returned(s.window->came_back);
    m.window().blocks_dropped(s.window->dropped);
    m.window().bytes_stored(s.window->bytes_stored);
    m.window().store_failures(s.window->store_failures);
    m.window().robots_forgotten(s.window->robots_forgotten);
    m.window().blocks_loaded_for_queries(s.window->loaded_for_queries);
    m.window().query_load_failures(s.window->query_load_failures);
    m.window().dense_blocks_dropped(s.window->dense_blocks_dropped);
  }
  return m;
}

msg::RobotProgress toWire(const durability::RobotProgress& p, const std::string& server_id,
                          std::uint64_t incarnation, bool journal, const std::string& only_robot) {
  msg::RobotProgress m;
  m.server_id(server_id);
  m.incarnation(incarnation);
  m.stamp_ns(util::wallClockNs());
  m.journal(journal);
  p.forEachRobot([&](const std::string& id, std::uint64_t count, std::uint64_t, std::uint64_t last) {
    if (!only_robot.empty() && id != only_robot) return;
    msg::RobotDurability r;
    r.robot_id(id);
    r.last_durable_sequence(last);
    r.durable_scans(count);
    for (const auto& [first, l] : p.recentIntervals(id, 256)) {
      r.intervals().push_back(first);
      r.intervals().push_back(l);
    }
    for (const auto& [first, l] : p.appliedOrder(id, 256)) {
      r.applied_order().push_back(first);
      r.applied_order().push_back(l);
    }
    m.robots().push_back(std::move(r));
  });
  return m;
}

}  // namespace densemap::server::dds_edge
