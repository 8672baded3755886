#include "densemap/server/app/server_config.h"

#include "densemap/cli/common_options.h"
#include "densemap/msg/dds_options_cli.h"
#include "densemap/server/ros2_edge/ros2_options.h"
#include "densemap/server/service_option_table.h"

namespace densemap::server::app {

std::vector<options::OptionTable> serverOptionTables(ServerConfig& c) {
  std::vector<options::OptionTable> tables;
  tables.push_back(msg::ddsOptions(c.edge.dds));
  tables.push_back(map::mapOptionTable(c.service.map));
  tables.push_back(update::updateOptionTable(c.service.update));
  for (auto& t : serviceOptionTables(c.service)) tables.push_back(std::move(t));
  tables.push_back(dds_edge::edgeOptions(c.edge));
  tables.push_back(ros2_edge::ros2Options(c.ros2));
  tables.push_back(cli::loggingOptions(c.log_level));
  return tables;
}

std::string defaultServerToml() {
  ServerConfig defaults;
  const auto tables = serverOptionTables(defaults);
  std::vector<const options::OptionTable*> list;
  for (const auto& t : tables) list.push_back(&t);
  return options::toToml(
      list,
      "# densemap-server's configuration: every key is a long command-line option (flags given on the\n"
      "# command line win). The values are the defaults; the server needs no file at all.\n"
      "#   ./build/server/densemap-server --config config/server.toml\n"
      "# Generated from the option tables: densemap-server --print-config > config/server.toml\n");
}

}  // namespace densemap::server::app
