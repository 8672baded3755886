// The mapping service's options, declared once (name, default, range, help): densemap-server's flags, its
// configuration keys, --help and config/server.toml come from these tables, and MapService validates
// its options against them.
#pragma once

#include <vector>

#include "densemap/options/option_table.h"
#include "densemap/server/service_options.h"

namespace densemap::server {

/// The service's own tables (server, densify, dense layer, pipeline, storage, shutdown). The map and
/// update tables are the shared ones (cli::mapOptions, cli::updateOptions) on options.map / .update.
std::vector<options::OptionTable> serviceOptionTables(ServiceOptions& options);

/// Checks every option (the service's tables and the map and update ones); throws std::invalid_argument
/// naming the option that is out of range.
void validateServiceOptions(const ServiceOptions& options);

}  // namespace densemap::server
