// densemap-server's whole configuration, service and DDS edge, and the list of its option tables in the
// order config/server.toml shows them (that file is generated from them: densemap-server --print-config).
#pragma once

#include <string>
#include <vector>

#include "densemap/cli/option_table.h"
#include "densemap/server/dds_edge/dds_edge.h"
#include "densemap/server/ros2_edge/ros2_edge.h"
#include "densemap/server/service_options.h"

namespace densemap::server::dds_edge {

struct ServerConfig {
  ServiceOptions service{};
  DdsEdgeOptions edge{};
  ros2_edge::Ros2EdgeOptions ros2{};
  std::string log_level = "info";
};

/// The DDS edge's own options (queries and statistics).
cli::OptionTable edgeOptions(DdsEdgeOptions& options);

/// Every option of densemap-server: DDS, map, update, the service's, the edge's, logging.
std::vector<cli::OptionTable> serverOptionTables(ServerConfig& config);

/// config/server.toml as the defaults make it.
std::string defaultServerToml();

}  // namespace densemap::server::dds_edge
