// densemap-query: every query kind from the command line, human-readable or --json, and `render` (PNG).
#include <cstdio>
#include <memory>
#include <sstream>
#include <thread>

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "densemap/cli/cli_common.h"
#include "densemap/cli/common_options.h"
#include "densemap/cli/option_cli.h"
#include "densemap/client/joining_client.h"
#include "densemap/client/map_render.h"
#include "densemap/client/query_client.h"
#include "densemap/client/server_join.h"
#include "densemap/client/statistics_subscriber.h"
#include "densemap/msg/dds_options_cli.h"
#include "densemap/msg/wire_types.h"

using namespace densemap;
using nlohmann::json;

namespace {

std::array<float, 3> parseXyz(const std::string& s) {
  std::array<float, 3> v{};
  char c1 = 0, c2 = 0;
  std::istringstream in(s);
  if (!(in >> v[0] >> c1 >> v[1] >> c2 >> v[2]) || c1 != ',' || c2 != ',' || !in.eof()) {
    throw std::invalid_argument("'" + s + "' is not a point; write x,y,z (e.g. 1.5,-2,0.3)");
  }
  return v;
}

std::string stateName(std::uint8_t s) {
  return s == msg::CELL_OCCUPIED        ? "occupied"
         : s == msg::CELL_FREE          ? "free"
         : s == msg::CELL_NOT_IN_MEMORY ? "not in memory (stored)"
                                        : "unknown";
}

json statsJson(const msg::MapStatistics& s) {
  return {{"backend", s.backend()},
          {"resolution", s.resolution()},
          {"map_version", s.map_version()},
          {"known_cells", s.known_cells()},
          {"occupied_cells", s.occupied_cells()},
          {"memory_bytes", s.memory_bytes()},
          {"bounds_min", s.bounds_min()},
          {"bounds_max", s.bounds_max()}};
}

json serverStatisticsJson(const msg::ServerStatistics& s) {
  json robots = json::array(), stages = json::array();
  for (const auto& r : s.robots()) {
    robots.push_back({{"robot", r.robot_id()},
                      {"received", r.received()},
                      {"processed", r.processed()},
                      {"dropped", r.dropped()},
                      {"rejected", r.rejected()},
                      {"points_rejected", r.points_rejected()},
                      {"queue_depth", r.queue_depth()},
                      {"last_sequence", r.last_sequence()},
                      {"duplicates", r.duplicates()},
                      {"durable_scans", r.durable_scans()},
                      {"journaled_scans", r.journaled_scans()},
                      {"last_durable_sequence", r.last_durable_sequence()}});
  }
  for (const auto& st : s.stages()) {
    stages.push_back({{"name", st.name()},
                      {"processed", st.processed()},
                      {"dropped", st.dropped()},
                      {"latency_p50_ms", st.latency_p50_ms()},
                      {"latency_p99_ms", st.latency_p99_ms()}});
  }
  nlohmann::json methods = nlohmann::json::object();
  for (const auto& m : s.update_methods()) methods[m.method()] = m.scans();
  return {{"server_id", s.server_id()},
          {"uptime_s", s.uptime_s()},
          {"robots", robots},
          {"stages", stages},
          {"map", statsJson(s.map_stats())},
          {"publish_to_map_p50_ms", s.publish_to_map_p50_ms()},
          {"publish_to_map_p99_ms", s.publish_to_map_p99_ms()},
          {"queries_answered", s.queries_answered()},
          {"queries_failed", s.queries_failed()},
          {"commands_done", s.commands_done()},
          {"commands_failed", s.commands_failed()},
          {"resident_mb", static_cast<double>(s.resident_bytes()) / 1e6},
          {"heap_in_use_mb", static_cast<double>(s.heap_in_use_bytes()) / 1e6},
          {"heap_free_mb", static_cast<double>(s.heap_free_bytes()) / 1e6},
          {"samples_undecodable", s.samples_undecodable()},
          {"participants_refused", s.participants_refused()},
          {"journal",
           {{"on", s.journal()},
            {"failed", s.journal_failed()},
            {"bytes", s.journal_bytes()},
            {"syncs", s.journal_syncs()},
            {"failures", s.journal_failures()},
            {"snapshots", s.snapshots()},
            {"recovered_records", s.recovered_records()}}},
          {"window",
           {{"on", s.window().enabled()},
            {"blocks_out_of_memory", s.window().blocks_out_of_memory()},
            {"blocks_evicted", s.window().blocks_evicted()},
            {"blocks_returned", s.window().blocks_returned()},
            {"blocks_dropped", s.window().blocks_dropped()},
            {"bytes_stored", s.window().bytes_stored()},
            {"store_failures", s.window().store_failures()},
            {"robots_forgotten", s.window().robots_forgotten()},
            {"blocks_loaded_for_queries", s.window().blocks_loaded_for_queries()},
            {"query_load_failures", s.window().query_load_failures()},
            {"dense_blocks_dropped", s.window().dense_blocks_dropped()}}},
          {"update_method", s.update_method()},
          {"update_methods", methods}};
}

/// Fails with the reply's status and message when it is not OK.
template <class Reply>
void check(const Reply& r) {
  if (r.status() != msg::STATUS_OK) {
    throw std::runtime_error("server: " + client::toString(r.status()) + ": " + r.message());
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"densemap-query: ask a running densemap-server about its map"};
  msg::DdsOptions dds;
  bool as_json = false;
  double timeout_s = 10.0;
  std::string layer_name = "occupancy", log_level = "warn";
  auto dds_table = msg::ddsOptions(dds);
  auto logging_table = cli::loggingOptions(log_level);
  client::JoinOptions join_options;
  auto join_table = client::joinOptions(join_options);
  cli::addToApp(app, {&dds_table, &join_table, &logging_table});
  app.add_flag("--json", as_json, "print one JSON object instead of text");
  app.add_option("--timeout", timeout_s, "seconds to wait for each reply (the wait for the server is --wait)")
      ->capture_default_str();
  app.add_option("--layer", layer_name, "occupancy (exact log-odds map), dense or fused")
      ->capture_default_str()
      ->check(CLI::IsMember({"occupancy", "dense", "fused"}));
  app.require_subcommand(1);

  std::vector<std::string> point_args;
  auto* points = app.add_subcommand("points", "probability and state (free/occupied/unknown) per point");
  points->add_option("xyz", point_args, "points as x,y,z")->required();
  std::string box_min, box_max;
  std::uint32_t limit = 0;
  auto* box = app.add_subcommand("box", "occupied cells inside an axis-aligned box");
  box->add_option("--min", box_min, "lower corner x,y,z")->required();
  box->add_option("--max", box_max, "upper corner x,y,z")->required();
  box->add_option("--limit", limit, "most cells to return (0: server default)");
  std::string origin, direction;
  float max_range = 50.0f;
  bool ignore_unknown = false;
  auto* ray = app.add_subcommand("ray", "first occupied cell along a ray");
  ray->add_option("--origin", origin, "ray origin x,y,z")->required();
  ray->add_option("--direction", direction, "direction x,y,z")->required();
  ray->add_option("--max-range", max_range, "metres")->capture_default_str();
  ray->add_flag("--ignore-unknown", ignore_unknown, "let the ray pass through unknown cells");
  auto* stats = app.add_subcommand("stats", "map statistics");
  auto* server_stats = app.add_subcommand(
      "statistics",
      "the server's next periodic statistics: per-robot counters, latencies, memory (a health check)");
  auto* progress = app.add_subcommand(
      "progress", "what the server keeps of each robot: its durable sequence numbers (the journal)");
  std::string map_name;
  auto* save = app.add_subcommand("save", "save the map as NAME.bt or NAME.ot in the server's map directory");
  save->add_option("name", map_name,
                   "a file name (no path): NAME.bt keeps each cell's state, NAME.ot its log-odds")
      ->required();
  auto* load =
      app.add_subcommand("load", "replace the server's map with NAME.bt or NAME.ot from its map directory");
  load->add_option("name", map_name, "a file name in the server's map directory")->required();
  auto* clear = app.add_subcommand("clear", "forget every cell in a box");
  clear->add_option("--min", box_min, "lower corner x,y,z")->required();
  clear->add_option("--max", box_max, "upper corner x,y,z")->required();
  auto* reset = app.add_subcommand("reset", "forget the whole map");
  std::string png = "map.png", area_min, area_max;
  float slice_height = 1.0f, pixel = 0.0f;
  auto* render = app.add_subcommand("render", "PNG: top-down occupied cells by height | probability slice");
  render->add_option("--output", png, "PNG file to write")->capture_default_str();
  render->add_option("--height", slice_height, "z of the probability slice in metres")->capture_default_str();
  render->add_option("--pixel", pixel, "metres per pixel (default: the map resolution)");
  render->add_option("--min", area_min, "lower corner x,y of the area (default: the map's bounds)");
  render->add_option("--max", area_max, "upper corner x,y of the area");
  if (const auto rc = cli::parse(app, argc, argv, {&dds_table, &join_table, &logging_table})) return *rc;
  cli::setupLogging(log_level);

  try {
    dds.name = "densemap-query";
    // Handed to the query or admin client, which makes it again when a secure join stalls
    // (client/joining_client.h).
    auto node = std::make_unique<msg::DdsNode>(dds);
    const auto timeout = std::chrono::milliseconds(static_cast<long>(timeout_s * 1000));
    if (*progress) {
      // Published (transient local): the last message reaches a reader that joins later.
      auto* topic = node->topic(msg::kRobotProgressTopic, msg::typeSupport<msg::RobotProgressPubSubType>());
      auto* reader = node->reader(topic, msg::progressReaderQos(), nullptr);
      msg::RobotProgress p;
      eprosima::fastdds::dds::SampleInfo info;
      const client::JoinContext context = client::joinContext(
          dds, *node, "a densemap-server's progress on " + node->topicName(msg::kRobotProgressTopic));
      const client::ServerJoin got = client::joinServerWith(
          [&] {
            return client::JoinTarget{
                [&](std::chrono::milliseconds t) {
                  const auto until = std::chrono::steady_clock::now() + t;
                  for (;;) {
                    if (reader->take_next_sample(&p, &info) == ReturnCode_t::RETCODE_OK && info.valid_data)
                      return true;
                    if (std::chrono::steady_clock::now() >= until) return false;
                    std::this_thread::sleep_for(std::chrono::milliseconds(20));
                  }
                },
                [] { return std::string("no progress message yet"); }};
          },
          [] {}, join_options.wait(), join_options.wait(), &context);
      if (!got.joined)
        throw std::runtime_error(client::noServerMessage(context, join_options.wait(), got.state));
      json robots = json::array();
      for (const auto& r : p.robots()) {
        json iv = json::array();
        for (std::size_t i = 0; i + 1 < r.intervals().size(); i += 2)
          iv.push_back({r.intervals()[i], r.intervals()[i + 1]});
        robots.push_back({{"robot", r.robot_id()},
                          {"durable_scans", r.durable_scans()},
                          {"last_durable_sequence", r.last_durable_sequence()},
                          {"intervals", iv},
                          {"applied_order", [&] {
                             json o = json::array();
                             for (std::size_t i = 0; i + 1 < r.applied_order().size(); i += 2)
                               o.push_back({r.applied_order()[i], r.applied_order()[i + 1]});
                             return o;
                           }()}});
      }
      const json out = {{"server_id", p.server_id()}, {"journal", p.journal()}, {"robots", robots}};
      if (as_json) {
        std::printf("%s\n", out.dump().c_str());
      } else {
        std::printf("server %s (journal %s)\n", p.server_id().c_str(), p.journal() ? "on" : "off");
        for (const auto& r : robots)
          std::printf("  %s: %llu durable scans, up to %llu; runs %s\n",
                      r["robot"].get<std::string>().c_str(),
                      static_cast<unsigned long long>(r["durable_scans"].get<std::uint64_t>()),
                      static_cast<unsigned long long>(r["last_durable_sequence"].get<std::uint64_t>()),
                      r["intervals"].dump().c_str());
      }
      return 0;
    }
    if (*server_stats) {
      // Statistics are published, not asked for: no request-reply, so it also works while queries queue.
      client::StatisticsSubscriber sub(*node);
      std::optional<msg::ServerStatistics> s;
      const client::JoinContext context =
          client::joinContext(dds, *node,
                              "a densemap-server's statistics on " + node->topicName(msg::kStatisticsTopic) +
                                  " (servers with --statistics-period 0 publish none)");
      const client::ServerJoin got = client::joinServerWith(
          [&] {
            return client::JoinTarget{
                [&](std::chrono::milliseconds t) { return (s = sub.waitForNext(t)).has_value(); },
                [] { return std::string("no statistics message yet"); }};
          },
          [] {}, join_options.wait(), join_options.wait(), &context);
      if (!got.joined)
        throw std::runtime_error(client::noServerMessage(context, join_options.wait(), got.state));
      const json out = serverStatisticsJson(*s);
      if (as_json) {
        std::printf("%s\n", out.dump().c_str());
      } else {
        std::printf(
            "server %s, up %.0f s: %llu queries answered (%llu failed), publish-to-map p50 %.1f ms, "
            "p99 %.1f ms, resident %.0f MB (heap: %.0f MB in use, %.0f MB free in the allocator)\n",
            s->server_id().c_str(), s->uptime_s(), static_cast<unsigned long long>(s->queries_answered()),
            static_cast<unsigned long long>(s->queries_failed()), s->publish_to_map_p50_ms(),
            s->publish_to_map_p99_ms(), static_cast<double>(s->resident_bytes()) / 1e6,
            static_cast<double>(s->heap_in_use_bytes()) / 1e6,
            static_cast<double>(s->heap_free_bytes()) / 1e6);
        if (s->window().enabled()) {
          const auto& w = s->window();
          std::printf(
              "  map window: %llu blocks out of memory; this run %llu left, %llu came back, %llu dropped, "
              "%.1f MB stored, %llu store failures\n",
              static_cast<unsigned long long>(w.blocks_out_of_memory()),
              static_cast<unsigned long long>(w.blocks_evicted()),
              static_cast<unsigned long long>(w.blocks_returned()),
              static_cast<unsigned long long>(w.blocks_dropped()),
              static_cast<double>(w.bytes_stored()) / 1e6,
              static_cast<unsigned long long>(w.store_failures()));
        }
        if (s->participants_refused() > 0) {
          std::printf("  %llu participants refused by DDS-Security (authentication or permissions failed)\n",
                      static_cast<unsigned long long>(s->participants_refused()));
        }
        for (const auto& r : s->robots()) {
          std::printf("  %s: received %llu, processed %llu, dropped %llu, rejected %llu, queue %u/%u\n",
                      r.robot_id().c_str(), static_cast<unsigned long long>(r.received()),
                      static_cast<unsigned long long>(r.processed()),
                      static_cast<unsigned long long>(r.dropped()),
                      static_cast<unsigned long long>(r.rejected()), r.queue_depth(), r.queue_capacity());
        }
      }
      return 0;
    }
    const std::string client_id = client::clientIdOf(*node, "query-" + std::to_string(::getpid()));
    // Waits for the server through a client that owns the participant from here on.
    const auto joined = [&](auto& c, const char* topic) -> auto& {
      const client::JoinContext context =
          client::joinContext(dds, c.node(), "a densemap-server answering on " + c.node().topicName(topic));
      const auto j = c.join(join_options.wait(), join_options.attempt(c.node().secure()), &context);
      if (!j.joined) throw std::runtime_error(client::noServerMessage(context, join_options.wait(), j.state));
      return c.client();
    };
    if (*save || *load || *clear || *reset) {
      // Commands go to the admin topic (a permissions file may grant queries but not these).
      client::JoiningClient<client::AdminClient, std::string> admin(dds, client_id, std::move(node));
      client::AdminClient& ac = joined(admin, msg::kAdminRequestTopic);
      const msg::AdminRequest rq = *save    ? client::saveRequest(map_name)
                                   : *load  ? client::loadRequest(map_name)
                                   : *clear ? client::clearBoxRequest(parseXyz(box_min), parseXyz(box_max))
                                            : client::resetRequest();
      // A save or load of a large map takes a while: allow a minute beyond --timeout.
      const auto r = ac.call(rq, timeout + std::chrono::seconds(60));
      check(r);
      json out = {
          {"map_version", r.map_version()}, {"cells_changed", r.cells_changed()}, {"message", r.message()}};
      if (*save || *load) out["map"] = statsJson(r.stats());
      out["server_id"] = r.server_id();
      if (as_json) {
        std::printf("%s\n", out.dump().c_str());
      } else {
        std::printf("%s\n", r.message().c_str());
      }
      return 0;
    }
    client::JoiningClient<client::QueryClient, std::string> query(dds, client_id, std::move(node));
    client::QueryClient& qc = joined(query, msg::kQueryRequestTopic);
    msg::QueryRequest rq;
    rq.layer(layer_name == "dense"   ? msg::LAYER_DENSE
             : layer_name == "fused" ? msg::LAYER_FUSED
                                     : msg::LAYER_OCCUPANCY);
    json out;
    std::string server_id;  // which server answered (one per namespace)
    if (*points) {
      rq.kind(msg::QUERY_POINTS);
      for (const auto& p : point_args) {
        const auto v = parseXyz(p);
        rq.points().insert(rq.points().end(), v.begin(), v.end());
      }
      const auto r = qc.call(rq, timeout);
      check(r);
      server_id = r.server_id();
      out["map_version"] = r.map_version();
      for (std::size_t i = 0; i < r.states().size(); ++i) {
        out["points"].push_back(
            {{"xyz", {rq.points()[3 * i], rq.points()[3 * i + 1], rq.points()[3 * i + 2]}},
             {"probability", r.probabilities()[i]},
             {"state", stateName(r.states()[i])}});
        if (!as_json) {
          std::printf("%s  p=%.3f  %s\n", point_args[i].c_str(), r.probabilities()[i],
                      stateName(r.states()[i]).c_str());
        }
      }
    } else if (*box) {
      rq = client::boxRequest(msg::QUERY_BOX, parseXyz(box_min), parseXyz(box_max));
      rq.limit(limit);
      const auto r = qc.call(rq, timeout);
      check(r);
      server_id = r.server_id();
      const std::size_t n = r.cells().size() / 3;
      out = {{"map_version", r.map_version()},
             {"occupied_cells", n},
             {"truncated", r.truncated()},
             {"blocks_not_in_memory", r.blocks_not_in_memory()},
             {"cells", r.cells()}};
      if (!as_json) {
        std::printf("%zu occupied cells%s\n", n, r.truncated() ? " (truncated at the limit)" : "");
        if (r.blocks_not_in_memory() > 0)
          std::printf("  %u map blocks in the box are stored out of memory (map window): not listed\n",
                      r.blocks_not_in_memory());
        for (std::size_t i = 0; i < std::min<std::size_t>(n, 20); ++i) {
          std::printf("  %.2f %.2f %.2f\n", r.cells()[3 * i], r.cells()[3 * i + 1], r.cells()[3 * i + 2]);
        }
        if (n > 20) std::printf("  ... (--json prints all)\n");
      }
    } else if (*ray) {
      rq.kind(msg::QUERY_RAY);
      rq.ray_origin(parseXyz(origin));
      rq.ray_direction(parseXyz(direction));
      rq.max_range(max_range);
      rq.ignore_unknown(ignore_unknown);
      const auto r = qc.call(rq, timeout);
      check(r);
      server_id = r.server_id();
      out = {{"map_version", r.map_version()},
             {"hit", r.hit()},
             {"hit_point", r.hit_point()},
             {"reached_not_in_memory", r.ray_reached_not_in_memory()},
             {"message", r.message()}};
      if (!as_json) {
        if (r.hit()) {
          std::printf("hit %.2f %.2f %.2f (%s)\n", r.hit_point()[0], r.hit_point()[1], r.hit_point()[2],
                      r.message().c_str());
        } else {
          std::printf("no hit: %s\n", r.message().c_str());
        }
      }
    } else if (*stats) {
      rq.kind(msg::QUERY_STATS);
      const auto r = qc.call(rq, timeout);
      check(r);
      server_id = r.server_id();
      out = statsJson(r.stats());
      if (!as_json) {
        const auto& s = r.stats();
        std::printf(
            "%s map, %.2f m, version %llu: %llu known cells (%llu occupied), %.1f MB\n"
            "bounds %.1f %.1f %.1f .. %.1f %.1f %.1f\n",
            s.backend().c_str(), s.resolution(), static_cast<unsigned long long>(s.map_version()),
            static_cast<unsigned long long>(s.known_cells()),
            static_cast<unsigned long long>(s.occupied_cells()), static_cast<double>(s.memory_bytes()) / 1e6,
            s.bounds_min()[0], s.bounds_min()[1], s.bounds_min()[2], s.bounds_max()[0], s.bounds_max()[1],
            s.bounds_max()[2]);
      }
    } else if (*render) {
      msg::QueryRequest srq;
      srq.kind(msg::QUERY_STATS);
      const auto s = qc.call(srq, timeout);
      check(s);
      const auto& st = s.stats();
      if (st.known_cells() == 0) throw std::runtime_error("the map is empty: nothing to render");
      client::RenderArea area;
      area.pixel = pixel > 0 ? pixel : static_cast<float>(st.resolution());
      area.x0 = st.bounds_min()[0];
      area.y0 = st.bounds_min()[1];
      area.x1 = st.bounds_max()[0];
      area.y1 = st.bounds_max()[1];
      if (!area_min.empty()) {
        const auto v = parseXyz(area_min + ",0");
        area.x0 = v[0];
        area.y0 = v[1];
      }
      if (!area_max.empty()) {
        const auto v = parseXyz(area_max + ",0");
        area.x1 = v[0];
        area.y1 = v[1];
      }
      if (area.width() * area.height() > 16'000'000) {
        throw std::invalid_argument(
            "the picture would be too large; pass a larger --pixel or a smaller area");
      }
      auto brq = client::boxRequest(msg::QUERY_BOX, {area.x0, area.y0, st.bounds_min()[2]},
                                    {area.x1, area.y1, st.bounds_max()[2]});
      brq.layer(rq.layer());
      brq.limit(2'000'000);
      const auto cells = qc.call(brq, timeout);
      check(cells);
      const auto top = client::renderTopDown(cells.cells(), area, st.bounds_min()[2], st.bounds_max()[2]);
      // The slice: one point query per pixel centre, in chunks the server accepts.
      const int w = area.width(), h = area.height();
      std::vector<float> probs;
      std::vector<std::uint8_t> states;
      msg::QueryRequest prq;
      prq.kind(msg::QUERY_POINTS);
      prq.layer(rq.layer());
      for (int y = 0; y < h; ++y) {
        for (int x = 0; x < w; ++x) {
          prq.points().insert(prq.points().end(),
                              {area.x0 + (static_cast<float>(x) + 0.5f) * area.pixel,
                               area.y1 - (static_cast<float>(y) + 0.5f) * area.pixel, slice_height});
          if (prq.points().size() >= 3 * 250'000 || (y == h - 1 && x == w - 1)) {
            const auto r = qc.call(prq, timeout);
            check(r);
            probs.insert(probs.end(), r.probabilities().begin(), r.probabilities().end());
            states.insert(states.end(), r.states().begin(), r.states().end());
            prq.points().clear();
          }
        }
      }
      const auto slice = client::renderSlice(probs, states, w, h);
      client::writePng(png, client::sideBySide(top, slice));
      out = {{"output", png},
             {"width", 2 * w + 8},
             {"height", h},
             {"occupied_cells", cells.cells().size() / 3},
             {"slice_height", slice_height},
             {"map_version", st.map_version()}};
      if (!as_json) {
        std::printf(
            "wrote %s (%dx%d): left, %zu occupied cells from above coloured by height %.1f..%.1f m; right, "
            "probability slice at z = %.2f m (grey: unknown)\n",
            png.c_str(), 2 * w + 8, h, cells.cells().size() / 3, st.bounds_min()[2], st.bounds_max()[2],
            slice_height);
      }
    }
    if (as_json && out.is_object()) out["server_id"] = server_id;
    if (as_json) std::printf("%s\n", out.dump().c_str());
  } catch (const std::exception& e) {
    if (as_json) {
      std::printf("%s\n", json{{"error", e.what()}}.dump().c_str());
    }
    spdlog::error("{}", e.what());
    return 1;
  }
  return 0;
}
