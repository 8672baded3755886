// densemap-eval as a user runs it, on the built-in simulator (no data needed): one JSON object per method
// with the documented fields, sensible scores, and the ROC files.
#include <filesystem>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "run_command.h"
#include "test_data.h"

namespace {

std::string run(const std::string& command, int& status) {
  const densemap::test::CommandResult r = densemap::test::runCommand(command);
  status = r.wait_status;
  return r.output;
}

TEST(EvalTool, JsonPerMethodRocCsvAndPng) {
  const auto dir = std::filesystem::temp_directory_path() / "densemap_eval_tool";
  std::filesystem::create_directories(dir);
  int status = 0;
  const std::string out =
      run(std::string(DENSEMAP_EVAL_BINARY) +
              " --source sim:scans=3,beams=16,columns=256 --resolution 0.2 --max-range 30 --json"
              " --roc-csv " +
              (dir / "roc.csv").string() + " --roc-png " + (dir / "roc.png").string(),
          status);
  ASSERT_EQ(status, 0) << out;
  std::istringstream lines(out);
  std::map<std::string, nlohmann::json> by_method;
  for (std::string line; std::getline(lines, line);) {
    const auto j = nlohmann::json::parse(line);
    by_method[j.at("method")] = j;
  }
  ASSERT_EQ(by_method.size(), 3u);
  for (const auto& [m, j] : by_method) {
    for (const char* key :
         {"auc", "mse", "acc_occupied", "acc_free", "coverage", "seconds_total", "ms_per_scan"}) {
      ASSERT_TRUE(j.contains(key)) << m << " lacks " << key;
    }
    EXPECT_GT(j.at("auc").get<double>(), 0.6) << m;
    EXPECT_LT(j.at("mse").get<double>(), 0.25) << m;
    EXPECT_GT(j.at("coverage").get<double>(), 0.5) << m;
  }
  // The kernel layers fill holes the exact map leaves.
  EXPECT_GT(by_method["akimap"].at("coverage").get<double>(),
            by_method["exact"].at("coverage").get<double>());
  EXPECT_GT(std::filesystem::file_size(dir / "roc.csv"), 100u);
  EXPECT_GT(std::filesystem::file_size(dir / "roc.png"), 1000u);
  std::filesystem::remove_all(dir);
}

double heldOutAuc(const std::string& densify) {
  int status = 0;
  const std::string out = run(std::string(DENSEMAP_EVAL_BINARY) + " --source " + densemap::test::dataDir() +
                                  "/kitti00 --scans 50:59 --resolution 0.2 --methods exact "
                                  "--keep-every-nth-beam 4 --json --densify " +
                                  densify,
                              status);
  EXPECT_EQ(status, 0) << out;
  return status == 0 ? nlohmann::json::parse(out).at("auc").get<double>() : 0.0;
}

TEST(EvalTool, IlnDensifiedSixteenRealBeamsMapBetterThanBilinearAndRaw) {
  // (Sec. 4.4.5's protocol): the map from every 4th beam of kitti00 scans 50-59, densified to 64
  // beams with the shipped (simulator-only) ILN, scores a higher held-out AUC on the other beams' points
  // than the same beams densified bilinearly or mapped raw.
  DENSEMAP_REQUIRE_DATA("kitti00");
  const double iln = heldOutAuc("iln"), bilinear = heldOutAuc("bilinear"), raw = heldOutAuc("none");
  EXPECT_GT(iln, bilinear);
  EXPECT_GT(iln, raw);
}

}  // namespace
