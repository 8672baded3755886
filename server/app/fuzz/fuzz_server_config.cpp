// libFuzzer target for densemap-server's configuration file: the TOML CLI11 reads for --config, bound to
// every option table (server/dds_edge/src/server_config.cpp), then the tables' commit and validation. A
// file is either accepted with every value in its declared range, or refused with CLI11's or the tables'
// error; anything else (another exception, a crash) is a bug.
//
// The application and its tables are built once (building them took most of each run); before every
// input each option's value is restored from a snapshot of the defaults and CLI11's results are cleared,
// so every input starts from the same state as a fresh densemap-server.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <variant>

#include <CLI/CLI.hpp>

#include "densemap/cli/option_cli.h"
#include "densemap/server/app/server_config.h"

namespace {

struct Fixture {
  densemap::server::app::ServerConfig config;
  std::vector<densemap::options::OptionTable> tables = densemap::server::app::serverOptionTables(config);
  std::vector<densemap::options::OptionTable*> list;
  CLI::App app{"fuzz"};
  std::vector<std::function<void()>> restore;  // every option's default, the enumerations' names included

  Fixture() {
    for (auto& t : tables) list.push_back(&t);
    densemap::cli::addToApp(app, list);
    for (auto* t : list)
      for (auto& o : t->options())
        std::visit([&](auto* p) { restore.push_back([p, v = *p] { *p = v; }); }, o.target);
  }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static Fixture f;
  f.config = densemap::server::app::ServerConfig{};
  for (const auto& r : f.restore) r();
  f.app.clear();
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  try {
    f.app.parse_from_stream(in);
    densemap::options::finishOptions(f.list);
    // Accepted: every table must now validate clean.
    for (const auto* t : f.list)
      if (!t->validate().empty()) __builtin_trap();
  } catch (const CLI::Error&) {
  } catch (const std::invalid_argument&) {
  }
  return 0;
}
