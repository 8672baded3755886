// densemap-bench's references: the benchmark runs densemap-octomap-reference, its octree maps
// equal the map that process builds, and the reference program refuses corrupt or foreign input with a
// message instead of crashing; the default method is judged against the best of the four and that
// method's own spread in the same run.
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include <sys/wait.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "densemap/eval/paired_timing.h"
#include "run_command.h"

namespace {

std::string run(const std::string& command, int& status) {
  const densemap::test::CommandResult r =
      densemap::test::runCommand(command, densemap::test::Stderr::kCapture);
  status = r.wait_status;
  return r.output;
}

std::filesystem::path scratch(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / "densemap_bench_reference";
  std::filesystem::create_directories(dir);
  return dir / name;
}

TEST(BenchReference, OctomapRunsInItsOwnProcessAndTheOctreeMapsEqualIts) {
  const auto graph = scratch("sim3.graph");
  int status = 0;
  const std::string out =
      run(std::string(DENSEMAP_BENCH_BINARY) +
              " --source sim:scans=3,beams=16,columns=256 --resolution 0.4 --backend octree"
              " --method baseline,culling --no-unnecessary --json --graph-out " +
              graph.string(),
          status);
  ASSERT_EQ(status, 0) << out;
  std::map<std::string, nlohmann::json> by_method;
  std::istringstream lines(out);
  for (std::string line; std::getline(lines, line);)
    if (!line.empty() && line[0] == '{')
      by_method[nlohmann::json::parse(line).at("method")] = nlohmann::json::parse(line);
  ASSERT_TRUE(by_method.count("octomap")) << out;
  EXPECT_EQ(by_method["octomap"]["reference"], "own process");
  EXPECT_GT(by_method["octomap"]["memory_bytes"].get<double>(), 0.0);
  for (const char* m : {"baseline", "culling"}) {
    ASSERT_TRUE(by_method.count(m)) << out;
    EXPECT_TRUE(by_method[m]["identical"].get<bool>()) << m;  // compared with the reference's own map
    EXPECT_GT(by_method[m]["speedup_vs_octomap"].get<double>(), 0.0);
  }
  // The kept scans, run by hand, give the same map size as the reference the benchmark ran.
  const std::string alone =
      run(std::string(DENSEMAP_OCTOMAP_REFERENCE_BINARY) + " --graph " + graph.string() + " --resolution 0.4",
          status);
  ASSERT_EQ(status, 0) << alone;
  const auto j = nlohmann::json::parse(alone);
  EXPECT_EQ(j["scans"], 3);
  EXPECT_EQ(j["memory_bytes"], by_method["octomap"]["memory_bytes"]);
  EXPECT_EQ(j["scan_ms"].size(), 3u);
}

std::map<std::string, nlohmann::json> fastestByBackend(const std::string& out) {
  std::map<std::string, nlohmann::json> by_backend;
  std::istringstream lines(out);
  for (std::string line; std::getline(lines, line);) {
    if (line.empty() || line[0] != '{') continue;
    const auto j = nlohmann::json::parse(line);
    if (j.at("method") == "fastest") by_backend[j.at("backend")] = j;
  }
  return by_backend;
}

TEST(BenchReference, FastestIsJudgedAgainstTheBestsOwnSpread) {
  const std::string command = std::string(DENSEMAP_BENCH_BINARY) +
                              " --source sim:scans=4,beams=16,columns=256 --resolution 0.4 --no-octomap"
                              " --no-unnecessary --method all --json --repeat ";
  int status = 0;
  const std::string out = run(command + "4", status);
  ASSERT_EQ(status, 0) << out;
  const auto fastest = fastestByBackend(out);
  ASSERT_EQ(fastest.size(), 2u) << out;  // grid and octree
  for (const auto& [backend, j] : fastest) {
    ASSERT_TRUE(j.contains("best_of_four_spread")) << j.dump();
    const double ratio = j.at("time_vs_best_of_four").get<double>();
    const double spread = j.at("best_of_four_spread").get<double>();
    EXPECT_GT(ratio, 0.0) << backend;
    EXPECT_GE(spread, 0.0) << backend;
    EXPECT_EQ(j.at("slower_than_best_beyond_spread").get<bool>(), ratio > 1.0 + spread) << j.dump();
    EXPECT_NE(j.at("best_of_four"), "fastest");
    // Paired against each of the four over the same 4 repetitions (sign test; 4 rounds cannot reach 5%).
    ASSERT_TRUE(j.contains("paired_vs")) << j.dump();
    ASSERT_EQ(j.at("paired_vs").size(), 4u) << j.dump();
    for (const auto& [other, t] : j.at("paired_vs").items()) {
      EXPECT_EQ(t.at("rounds").get<int>(), 4) << other;
      const int k = t.at("slower_rounds").get<int>();
      EXPECT_DOUBLE_EQ(t.at("p_value").get<double>(), densemap::eval::signTestPValue(k, 4)) << other;
      EXPECT_GT(t.at("median_ratio").get<double>(), 0.0) << other;
    }
    EXPECT_TRUE(j.at("measurably_slower_than").empty()) << j.dump();
  }
  // One run has no spread, so no verdict either.
  const std::string once = run(command + "1", status);
  ASSERT_EQ(status, 0) << once;
  for (const auto& [backend, j] : fastestByBackend(once)) {
    EXPECT_TRUE(j.contains("time_vs_best_of_four")) << j.dump();
    EXPECT_FALSE(j.contains("best_of_four_spread")) << j.dump();
  }
}

TEST(BenchReference, CorruptTruncatedOrMissingInputIsRefusedWithAMessage) {
  const auto graph = scratch("sim1.graph");
  int status = 0;
  run(std::string(DENSEMAP_BENCH_BINARY) +
          " --source sim:scans=1,beams=16,columns=256 --resolution 0.4 --backend grid --method baseline"
          " --no-unnecessary --json --graph-out " +
          graph.string(),
      status);
  ASSERT_EQ(status, 0);
  std::ifstream in(graph, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_GT(bytes.size(), 1000u);
  // OctoMap's own reader aborts on each of these; the reference program must say what is wrong and exit 1.
  const std::map<std::string, std::string> cases = {{"truncated.graph", bytes.substr(0, bytes.size() / 2)},
                                                    {"header-only.graph", bytes.substr(0, 10)},
                                                    {"garbage.graph", std::string(4000, '\xff')}};
  for (const auto& [name, content] : cases) {
    std::ofstream(scratch(name), std::ios::binary) << content;
    const std::string out =
        run(std::string(DENSEMAP_OCTOMAP_REFERENCE_BINARY) + " --graph " + scratch(name).string(), status);
    EXPECT_EQ(WEXITSTATUS(status), 1) << name << ": " << out;
    EXPECT_FALSE(WIFSIGNALED(status)) << name;
    EXPECT_NE(out.find("corrupt scan graph"), std::string::npos) << name << ": " << out;
  }
  const std::string missing =
      run(std::string(DENSEMAP_OCTOMAP_REFERENCE_BINARY) + " --graph /nonexistent.graph", status);
  EXPECT_EQ(WEXITSTATUS(status), 1);
  EXPECT_NE(missing.find("/nonexistent.graph"), std::string::npos) << missing;
}

}  // namespace
