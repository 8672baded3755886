// libFuzzer target for densemap-server's configuration file: the TOML CLI11 reads for --config, bound to
// every option table (server/dds_edge/src/server_config.cpp), then the tables' commit and validation. A
// file is either accepted with every value in its declared range, or refused with CLI11's or the tables'
// error; anything else (another exception, a crash) is a bug.
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <stdexcept>
#include <string>

#include <CLI/CLI.hpp>

#include "densemap/cli/option_cli.h"
#include "densemap/server/dds_edge/server_config.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  densemap::server::dds_edge::ServerConfig config;
  auto tables = densemap::server::dds_edge::serverOptionTables(config);
  std::vector<densemap::cli::OptionTable*> list;
  for (auto& t : tables) list.push_back(&t);
  CLI::App app{"fuzz"};
  app.allow_config_extras(false);
  densemap::cli::addToApp(app, list);
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  try {
    app.parse_from_stream(in);
    densemap::cli::finishOptions(list);
    // Accepted: every table must now validate clean.
    for (const auto* t : list)
      if (!t->validate().empty()) __builtin_trap();
  } catch (const CLI::Error&) {
  } catch (const std::invalid_argument&) {
  }
  return 0;
}
