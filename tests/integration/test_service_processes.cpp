// The programs as a user runs them: densemap-server in its own process, densemap-replay and densemap-query
// against it, then SIGTERM: a clean exit that saves the map.
#include <signal.h>
#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <string>
#include <thread>

#include <gtest/gtest.h>
#include <octomap/OcTree.h>
#include <nlohmann/json.hpp>

#include "run_command.h"
#include "spawn_process.h"

namespace densemap::test {
namespace {

using namespace std::chrono_literals;

/// Runs a command, returns its exit status and standard output.
std::pair<int, std::string> run(const std::string& command) {
  const CommandResult r = runCommand(command);
  return {r.exitCode(), r.output};
}

TEST(ServiceProcesses, EveryToolHasHelp) {
  for (const char* tool : {DENSEMAP_SERVER_BINARY, DENSEMAP_REPLAY_BINARY, DENSEMAP_QUERY_BINARY}) {
    const auto [rc, out] = run(std::string(tool) + " --help");
    EXPECT_EQ(rc, 0) << tool;
    EXPECT_NE(out.find("--domain"), std::string::npos) << tool << " --help must document --domain";
  }
}

TEST(ServiceProcesses, ReplayQueryAndCleanShutdownThatSavesTheMap) {
  const auto dir = std::filesystem::temp_directory_path() / "densemap_test_140";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string saved = (dir / "map.bt").string(), summary = (dir / "summary.json").string();
  const pid_t server =
      spawnProcess({DENSEMAP_SERVER_BINARY, "--domain", "140", "--loopback", "--statistics-period", "0.2",
                    "--save-on-exit", saved, "--data-dir", (dir / "data").string()});
  ASSERT_GT(server, 0);
  const std::string dds = " --domain 140 --loopback";
  const auto [replay_rc, replay_out] =
      run(std::string(DENSEMAP_REPLAY_BINARY) + dds +
          " --source sim:scans=4,beams=16,columns=256 --rate 20 --summary-json " + summary);
  EXPECT_EQ(replay_rc, 0) << replay_out;
  std::ifstream f(summary);
  ASSERT_TRUE(f) << "no summary written";
  const auto s = nlohmann::json::parse(f);
  EXPECT_EQ(s.at("scans_sent"), 4);
  EXPECT_EQ(s.at("scans_processed"), 4);
  EXPECT_EQ(s.at("scans_dropped"), 0);
  EXPECT_EQ(s.at("scans_rejected"), 0);
  EXPECT_GT(s.at("latency_p50_ms").get<double>(), 0.0);

  const auto [query_rc, query_out] = run(std::string(DENSEMAP_QUERY_BINARY) + dds + " --json stats");
  ASSERT_EQ(query_rc, 0) << query_out;
  const auto stats = nlohmann::json::parse(query_out);
  EXPECT_EQ(stats.at("map_version"), 4);
  const std::uint64_t known = stats.at("known_cells");
  EXPECT_GT(known, 1000u);
  const std::string png = (dir / "map.png").string();
  const auto [render_rc, render_out] =
      run(std::string(DENSEMAP_QUERY_BINARY) + dds + " render --output " + png);
  EXPECT_EQ(render_rc, 0) << render_out;
  EXPECT_GT(std::filesystem::file_size(png), 1000u);

  ASSERT_EQ(kill(server, SIGTERM), 0);
  int status = 0;
  for (int i = 0; i < 300 && waitpid(server, &status, WNOHANG) == 0; ++i) std::this_thread::sleep_for(100ms);
  ASSERT_TRUE(WIFEXITED(status)) << "the server did not exit within 30 s of SIGTERM";
  EXPECT_EQ(WEXITSTATUS(status), 0);
  octomap::OcTree tree(0.1);
  ASSERT_TRUE(tree.readBinary(saved)) << "the map was not saved on exit";
  std::size_t leaves = 0;
  for (auto it = tree.begin_leafs(); it != tree.end_leafs(); ++it) {
    const std::size_t side = std::size_t{1} << (16 - it.getDepth());
    leaves += side * side * side;
  }
  EXPECT_EQ(leaves, known);
  std::filesystem::remove_all(dir);
}

/// The server's environment as the kernel shows it (after any re-execution).
std::string environmentOf(pid_t pid) {
  std::ifstream f("/proc/" + std::to_string(pid) + "/environ", std::ios::binary);
  std::string env((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  for (char& c : env)
    if (c == '\0') c = '\n';
  return "\n" + env;
}

/// Stops the server with SIGTERM; its exit status, or -1 if it did not exit within 30 s.
int stopServer(pid_t server) {
  if (kill(server, SIGTERM) != 0) return -1;
  int status = 0;
  for (int i = 0; i < 300 && waitpid(server, &status, WNOHANG) == 0; ++i) std::this_thread::sleep_for(100ms);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// libgomp reads its idle-worker spin count before main, so the server executes itself again with
// GOMP_SPINCOUNT set (same pid) and then serves as usual; -1 leaves the environment alone.
TEST(ServiceProcesses, IdleOpenmpWorkersSpinAsConfigured) {
  if (std::getenv("GOMP_SPINCOUNT") != nullptr || std::getenv("OMP_WAIT_POLICY") != nullptr)
    GTEST_SKIP() << "GOMP_SPINCOUNT or OMP_WAIT_POLICY is set in this environment; it would win";
  const auto dir = std::filesystem::temp_directory_path() / "densemap_test_231";
  std::filesystem::remove_all(dir);
  for (const int spin : {1234, -1}) {
    const pid_t server =
        spawnProcess({DENSEMAP_SERVER_BINARY, "--domain", "231", "--loopback", "--update-idle-spin",
                      std::to_string(spin), "--data-dir", (dir / ("data" + std::to_string(spin))).string()});
    ASSERT_GT(server, 0);
    // Mapping still works in the re-executed process.
    const auto [replay_rc, replay_out] =
        run(std::string(DENSEMAP_REPLAY_BINARY) +
            " --domain 231 --loopback --source sim:scans=2,beams=16,columns=256");
    EXPECT_EQ(replay_rc, 0) << replay_out;
    const std::string env = environmentOf(server);
    if (spin >= 0) {
      EXPECT_NE(env.find("\nGOMP_SPINCOUNT=" + std::to_string(spin) + "\n"), std::string::npos)
          << "the server did not put --update-idle-spin into its environment";
    } else {
      EXPECT_EQ(env.find("\nGOMP_SPINCOUNT="), std::string::npos) << "-1 must leave libgomp's default";
    }
    std::ifstream comm("/proc/" + std::to_string(server) + "/comm");
    std::string name;
    std::getline(comm, name);
    EXPECT_EQ(name, "densemap-server") << "the re-executed server must keep its name (pgrep, top)";
    EXPECT_EQ(stopServer(server), 0);
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace densemap::test
