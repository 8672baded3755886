// densemap-server's whole configuration, service and DDS edge, and the list of its option tables in the
// order config/server.toml shows them (that file is generated from them: densemap-server --print-config).
#pragma once

#include <string>
#include <vector>

#include "densemap/options/option_table.h"
#include "densemap/server/dds_edge/dds_edge_options.h"
#include "densemap/server/ros2_edge/ros2_options.h"
#include "densemap/server/service_options.h"

namespace densemap::server::app {

struct ServerConfig {
  ServiceOptions service{};
  dds_edge::DdsEdgeOptions edge{};
  ros2_edge::Ros2EdgeOptions ros2{};
  std::string log_level = "info";
};

/// Every option of densemap-server: DDS, map, update, the service's, the edge's, logging.
std::vector<options::OptionTable> serverOptionTables(ServerConfig& config);

/// config/server.toml as the defaults make it.
std::string defaultServerToml();

}  // namespace densemap::server::app
