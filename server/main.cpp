// densemap-server: the mapping service under its DDS edge. Runs with no configuration; a TOML file
// (--config, same names as the long flags) and flags override the defaults. Every option is declared once,
// in an option table (densemap/server/app/server_config.h lists them).
#include <csignal>
#include <cstdio>

#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>

#include "densemap/cli/cli_common.h"
#include "densemap/cli/option_cli.h"
#include "densemap/server/app/server_config.h"
#include "densemap/server/dds_edge/dds_edge.h"
#include "densemap/server/map_service.h"
#include "densemap/server/openmp_idle_spin.h"
#include "densemap/server/ros2_edge/octomap_params.h"
#include "densemap/server/ros2_edge/ros2_edge.h"
#include "densemap/util/retain_freed_memory.h"

using namespace densemap;

int main(int argc, char** argv) {
  CLI::App app{"densemap-server: builds an occupancy map from LiDAR scans on DDS and answers queries"};
  server::app::ServerConfig config;
  auto tables = server::app::serverOptionTables(config);
  std::vector<options::OptionTable*> list;
  for (auto& t : tables) list.push_back(&t);
  app.set_config("--config", "", "TOML file with any of these options (flags override it)");
  bool print_config = false;
  app.add_flag("--print-config", print_config,
               "print the default configuration (config/server.toml) and exit");
  cli::addToApp(app, list);
  if (const auto rc = cli::parse(app, argc, argv, list)) return *rc;
  if (print_config) {
    std::fputs(server::app::defaultServerToml().c_str(), stdout);
    return 0;
  }
  cli::setupLogging(config.log_level);
  // Before any thread starts: this may execute the server again with the setting in its environment.
  server::applyOpenmpIdleSpin(config.service.update_idle_spin, argv);
  if (!config.ros2.params_file.empty()) {
    // octomap_server's parameters: they replace the defaults and the --config file; flags still win.
    try {
      const auto ignored = server::ros2_edge::applyOctomapParams(
          config.ros2.params_file, config.ros2.node_name,
          {&config.service.map, &config.service.update, &config.ros2}, [&](const std::string& flag) {
            return app.get_option_no_throw("--" + flag) != nullptr &&
                   app.get_option("--" + flag)->count() > 0;
          });
      for (const auto& why : ignored)
        spdlog::warn("--params-file {}: ignored {}", config.ros2.params_file, why);
    } catch (const std::invalid_argument& e) {
      spdlog::error("{}", e.what());
      return 2;
    }
  }
  if (config.ros2.only) config.ros2.enabled = true;
  densemap::util::retainFreedMemory();
  cli::setThreads(config.service.update_threads);

  // SIGINT/SIGTERM are taken by this thread only (blocked before any other thread starts).
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  try {
    server::MapService service(config.service);
    std::unique_ptr<server::dds_edge::DdsEdge> edge;
    if (!config.ros2.only) edge = std::make_unique<server::dds_edge::DdsEdge>(service, config.edge);
    std::unique_ptr<server::ros2_edge::Ros2Edge> ros2;
    if (config.ros2.enabled)
      ros2 = std::make_unique<server::ros2_edge::Ros2Edge>(service, config.ros2, config.edge.dds);
    // Until a signal, or until another server on the same topics turns out to have started first.
    int sig = -1;
    const timespec tick{0, 100'000'000};
    while (sig < 0 && !(edge && edge->refused())) sig = sigtimedwait(&signals, nullptr, &tick);
    if (sig >= 0) spdlog::info("received {}", sig == SIGINT ? "SIGINT" : "SIGTERM");
    if (ros2) ros2->stop();  // the intake first: no cloud enters after the service stops
    if (edge)
      edge->stop();
    else
      service.stop();
    if (sig < 0) {
      spdlog::error(
          "stopped: another densemap-server serves the same topics (see above); use --namespace to run both");
      return 1;
    }
    for (const auto& [id, r] : service.statistics().robots) {
      std::printf("robot %-16s received %llu, in map %llu, dropped %llu, rejected %llu\n", id.c_str(),
                  static_cast<unsigned long long>(r.received), static_cast<unsigned long long>(r.processed),
                  static_cast<unsigned long long>(r.dropped), static_cast<unsigned long long>(r.rejected));
    }
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
  return 0;
}
