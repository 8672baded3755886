// Options are declared once: config/server.toml is what the option tables generate (every option with its
// default), a file of those values parses back to the defaults, and out-of-range values are refused with
// the option's name, on the command line and when a MapService is built directly.
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <CLI/CLI.hpp>

#include "densemap/cli/option_cli.h"
#include "densemap/server/app/server_config.h"
#include "densemap/server/map_service.h"

namespace densemap::test {
namespace {

using server::app::ServerConfig;

std::string readFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// Parses `args` (and a --config file among them) into a fresh configuration.
ServerConfig parse(std::vector<std::string> args) {
  ServerConfig c;
  auto tables = server::app::serverOptionTables(c);
  std::vector<options::OptionTable*> list;
  for (auto& t : tables) list.push_back(&t);
  CLI::App app;
  app.set_config("--config");
  cli::addToApp(app, list);
  std::reverse(args.begin(), args.end());
  app.parse(args);
  cli::markGiven(app, list);
  options::finishOptions(list);
  return c;
}

TEST(ServerConfig, TheShippedFileIsWhatTheTablesGenerate) {
  const std::string shipped = readFile(std::string(DENSEMAP_SOURCE_DIR) + "/config/server.toml");
  EXPECT_EQ(shipped, server::app::defaultServerToml())
      << "config/server.toml is out of date: ./build/server/densemap-server --print-config > "
         "config/server.toml";
  // Every option appears in it as a key with its default (an empty list commented out).
  ServerConfig c;
  for (const auto& t : server::app::serverOptionTables(c))
    for (const auto& o : t.options()) {
      const bool listed = shipped.find("\n" + o.name + " = " + o.default_text) != std::string::npos ||
                          shipped.find("\n# " + o.name + " = " + o.default_text) != std::string::npos;
      EXPECT_TRUE(listed) << o.name;
    }
}

TEST(ServerConfig, TheShippedFileParsesToTheDefaults) {
  const ServerConfig parsed = parse({"--config", std::string(DENSEMAP_SOURCE_DIR) + "/config/server.toml"});
  ServerConfig defaults;
  ServerConfig copy = parsed;
  auto a = server::app::serverOptionTables(copy);
  auto b = server::app::serverOptionTables(defaults);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i)
    for (std::size_t j = 0; j < a[i].options().size(); ++j)
      EXPECT_EQ(options::tomlValue(a[i].options()[j].target), b[i].options()[j].default_text)
          << a[i].options()[j].name;
}

TEST(ServerConfig, FlagsAndEnumerationsFillTheOptions) {
  const ServerConfig c = parse({"--resolution", "0.1", "--method", "culling", "--overflow", "drop_oldest",
                                "--densify-robots", "a,b", "--drop-on-exit", "--query-threads", "4"});
  EXPECT_EQ(c.service.map.resolution, 0.1);
  EXPECT_EQ(c.service.update.method, update::UpdateMethod::kCullingRegion);
  EXPECT_EQ(c.service.pipeline.overflow, server::OverflowPolicy::kDropOldest);
  EXPECT_EQ(c.service.densify.robots, (std::vector<std::string>{"a", "b"}));
  EXPECT_TRUE(c.service.drop_on_exit);
  EXPECT_EQ(c.edge.query_threads, 4);
}

TEST(ServerConfig, TheAkimapPresetSetsWhatIsNotGivenAndGivenValuesWin) {
  const ServerConfig measured = parse({"--dense-layer", "akimap"});
  EXPECT_EQ(measured.service.dense.akimap_preset, "measured");
  EXPECT_TRUE(measured.service.dense.isotropic_free_kernels);
  EXPECT_DOUBLE_EQ(measured.service.dense.min_occupied_search_radius, 0.3);
  const ServerConfig dissertation = parse({"--akimap-preset", "dissertation"});
  EXPECT_FALSE(dissertation.service.dense.isotropic_free_kernels);
  EXPECT_DOUBLE_EQ(dissertation.service.dense.min_occupied_search_radius, 0.0);
  const ServerConfig mixed = parse({"--akimap-preset", "dissertation", "--dense-min-occupied-radius", "0.2"});
  EXPECT_FALSE(mixed.service.dense.isotropic_free_kernels);
  EXPECT_DOUBLE_EQ(mixed.service.dense.min_occupied_search_radius, 0.2);
  // In a configuration file too; the shipped file leaves both extensions commented out, so the preset
  // a user picks there (or on the command line) is not overridden by it.
  const std::string path = ::testing::TempDir() + "/preset.toml";
  std::ofstream(path) << "akimap-preset = \"dissertation\"\n";
  const ServerConfig from_file = parse({"--config", path});
  EXPECT_FALSE(from_file.service.dense.isotropic_free_kernels);
  EXPECT_DOUBLE_EQ(from_file.service.dense.min_occupied_search_radius, 0.0);
  const ServerConfig shipped_then_flag =
      parse({"--config", std::string(DENSEMAP_SOURCE_DIR) + "/config/server.toml", "--akimap-preset",
             "dissertation"});
  EXPECT_FALSE(shipped_then_flag.service.dense.isotropic_free_kernels);
  EXPECT_THROW(parse({"--akimap-preset", "fastest"}), std::exception);
}

TEST(ServerConfig, AMisspeltKeyInTheFileIsAnError) {
  const std::string path = ::testing::TempDir() + "/densemap_typo.toml";
  std::ofstream(path) << "resolutoin = 0.3\n";
  try {
    parse({"--config", path});
    ADD_FAILURE() << "a file with an unknown key was accepted";
  } catch (const CLI::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("resolutoin"), std::string::npos) << e.what();
  }
}

TEST(ServerConfig, OutOfRangeValuesAreRefusedByName) {
  for (const auto& [flag, value] :
       std::vector<std::pair<std::string, std::string>>{{"--resolution", "-1"},
                                                        {"--dense-nice", "25"},
                                                        {"--update-late-nice", "3"},
                                                        {"--domain", "300"},
                                                        {"--backend", "voxels"},
                                                        {"--prob-hit", "0.3"},
                                                        {"--realtime-priority", "100"}}) {
    try {
      parse({flag, value});
      ADD_FAILURE() << flag << " " << value << " was accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(flag), std::string::npos) << e.what();
    }
  }
  server::ServiceOptions o;
  o.dense_nice = 30;
  EXPECT_THROW(server::MapService{o}, std::invalid_argument) << "the service checks the same table";
}

}  // namespace
}  // namespace densemap::test
