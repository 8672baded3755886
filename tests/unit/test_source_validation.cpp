// Every source checks what it reads: a gap in a numbered sequence is an error (or, with
// --allow-gaps, the scans that are there on their own poses), a scan range past the end is an error,
// poses and calibrations must be rigid transforms and a NaN is reported as NaN, and a scan number too long
// to be one is named.
#include <filesystem>
#include <fstream>
#include <functional>

#include <unistd.h>

#include <gtest/gtest.h>

#include "densemap/cli/cli_common.h"
#include "densemap/io/kitti_odometry_source.h"
#include "densemap/io/lidar_simulator.h"
#include "densemap/io/numbered_files.h"
#include "densemap/io/pcd_file.h"
#include "densemap/io/scan_source.h"
#include "densemap/io/sequence_directory_source.h"
#include "densemap/sources/open_source.h"
#include "temp_dir.h"

namespace densemap::io {
namespace {

namespace fs = std::filesystem;
using test::TempDir;

::testing::AssertionResult throwsSaying(const std::function<void()>& f,
                                        const std::vector<std::string>& says) {
  try {
    f();
  } catch (const std::exception& e) {
    for (const auto& s : says)
      if (std::string(e.what()).find(s) == std::string::npos)
        return ::testing::AssertionFailure() << "error '" << e.what() << "' lacks '" << s << "'";
    return ::testing::AssertionSuccess();
  }
  return ::testing::AssertionFailure() << "no error";
}

void writePose(const fs::path& path, const Eigen::Matrix4d& m) {
  std::ofstream out(path);
  out.precision(17);
  for (int r = 0; r < 4; ++r) out << m(r, 0) << ' ' << m(r, 1) << ' ' << m(r, 2) << ' ' << m(r, 3) << '\n';
}

/// A sequence directory holding the simulator's scans with the given numbers.
std::vector<Scan> writeSequence(const fs::path& dir, const std::vector<int>& numbers) {
  LidarSimulatorOptions o;
  o.scans = 8;
  o.lidar.rows = 8;
  o.lidar.columns = 64;
  LidarSimulator sim(o);
  fs::create_directories(dir / "clouds");
  fs::create_directories(dir / "poses");
  std::vector<Scan> written;
  for (int n : numbers) {
    Scan s = sim.read(static_cast<std::size_t>(n));
    writePcd((dir / "clouds" / (std::to_string(n) + ".pcd")).string(), s.points);
    writePose(dir / "poses" / (std::to_string(n) + ".txt"), s.pose.matrix());
    written.push_back(std::move(s));
  }
  return written;
}

TEST(SourceValidation, SequenceGapIsAnErrorUnlessAllowed) {
  TempDir dir;
  const auto written = writeSequence(dir.path, {0, 1, 2, 5, 6});
  EXPECT_TRUE(throwsSaying([&] { (void)sources::openSource(dir.path.string()); },
                           {"scan 3 is missing", "--allow-gaps"}));
  sources::OpenOptions allow;
  allow.allow_gaps = true;
  const auto src = sources::openSource(dir.path.string(), allow);
  ASSERT_EQ(src->size(), 5u);
  // The scans after the gap keep their own clouds and poses.
  for (std::size_t i = 0; i < written.size(); ++i) {
    const Scan s = src->read(i);
    EXPECT_EQ(s.points, written[i].points) << i;
    EXPECT_TRUE(s.pose.isApprox(written[i].pose, 1e-12)) << i;
  }
}

TEST(SourceValidation, SequenceMissingScanZeroOrPoseFileIsAnError) {
  TempDir dir;
  writeSequence(dir.path / "a", {1, 2});
  EXPECT_TRUE(
      throwsSaying([&] { (void)sources::openSource((dir.path / "a").string()); }, {"scan 0 is missing"}));
  writeSequence(dir.path / "b", {0, 1});
  fs::remove(dir.path / "b" / "poses" / "1.txt");
  EXPECT_TRUE(
      throwsSaying([&] { (void)sources::openSource((dir.path / "b").string()); }, {"1.txt", "missing"}));
}

TEST(SourceValidation, EmptyCloudInASequenceIsAnErrorNotACrash) {
  TempDir dir;
  writeSequence(dir.path, {0, 1});
  std::ofstream(dir.path / "clouds" / "1.pcd", std::ios::trunc).close();
  const auto src = sources::openSource(dir.path.string());
  EXPECT_TRUE(throwsSaying([&] { src->read(1); }, {"1.pcd", "empty"}));
}

TEST(SourceValidation, ScanRangePastTheEndIsAnError) {
  EXPECT_TRUE(throwsSaying([] { cli::parseScanRange("0:6", 5); }, {"ends past", "last scan 4"}));
  EXPECT_EQ(cli::parseScanRange("2:", 5).last, 4u);
  EXPECT_EQ(cli::parseScanRange("0:4", 5).last, 4u);
}

TEST(SourceValidation, PoseMatricesMustBeRigidAndNanIsNamed) {
  Eigen::Matrix4d scaled = Eigen::Matrix4d::Identity() * 5.0;
  scaled(3, 3) = 1.0;
  EXPECT_TRUE(throwsSaying([] { parsePoseMatrix("1 0 0 nan 0 1 0 0 0 0 1 0 0 0 0 1", "p.txt"); },
                           {"p.txt", "entry (0,3) is nan"}));
  EXPECT_TRUE(
      throwsSaying([] { parsePoseMatrix("1 0 0 0 0 1 0 0 0 0 1 0 0 0 0", "p.txt"); }, {"holds 15 values"}));
  EXPECT_TRUE(
      throwsSaying([] { parsePoseMatrix("5 0 0 0 0 5 0 0 0 0 5 0 0 0 0 1", "p.txt"); }, {"not orthonormal"}));
  EXPECT_TRUE(
      throwsSaying([] { parsePoseMatrix("1 0 0 0 0 1 0 0 0 0 -1 0 0 0 0 1", "p.txt"); }, {"reflection"}));
  EXPECT_TRUE(
      throwsSaying([] { parsePoseMatrix("1 0 0 0 0 1 0 0 0 0 1 0 0 0 1 1", "p.txt"); }, {"last row"}));
  EXPECT_TRUE(throwsSaying([] { parsePoseMatrix("1 0 0 0 0 1 0 0 0 0 1 0x 0 0 0 1", "p.txt"); }, {"'0x'"}));
  EXPECT_TRUE(parsePoseMatrix("1 0 0 2.5 0 1 0 0 0 0 1 -1e3 0 0 0 1", "p.txt")
                  .translation()
                  .isApprox(Eigen::Vector3d(2.5, 0, -1e3)));
}

/// A KITTI layout with three simulated scans and the given calibration and pose lines.
void writeKitti(const fs::path& dir, const std::string& tr, const std::vector<std::string>& pose_lines,
                const std::vector<int>& bins = {0, 1, 2}) {
  fs::create_directories(dir / "velodyne");
  std::ofstream(dir / "calib.txt") << "P0: 1 0 0 0 0 1 0 0 0 0 1 0\nTr: " << tr << "\n";
  std::ofstream poses(dir / "poses.txt");
  for (const auto& l : pose_lines) poses << l << "\n";
  for (int n : bins) {
    char name[32];
    std::snprintf(name, sizeof name, "%06d.bin", n);
    std::ofstream bin(dir / "velodyne" / name, std::ios::binary);
    const float rec[8] = {1.0f + static_cast<float>(n), 2, 3, 0.5f, 4, 5, 6, 0.5f};
    bin.write(reinterpret_cast<const char*>(rec), sizeof rec);
  }
}

const std::string kIdentity34 = "1 0 0 0 0 1 0 0 0 0 1 0";

TEST(SourceValidation, KittiPosesAndCalibrationMustBeRigid) {
  TempDir dir;
  writeKitti(dir.path / "ok", kIdentity34,
             {kIdentity34, "1 0 0 1 0 1 0 0 0 0 1 0", "1 0 0 2 0 1 0 0 0 0 1 0"});
  EXPECT_EQ(sources::openSource((dir.path / "ok").string())->read(2).pose.translation().x(), 2.0);
  writeKitti(dir.path / "scaled", kIdentity34, {kIdentity34, "5 0 0 1 0 5 0 0 0 0 5 0", kIdentity34});
  EXPECT_TRUE(throwsSaying([&] { (void)sources::openSource((dir.path / "scaled").string()); },
                           {"poses.txt: line 2", "orthonormal"}));
  writeKitti(dir.path / "zero_tr", "0 0 0 0 0 0 0 0 0 0 0 0", {kIdentity34, kIdentity34, kIdentity34});
  EXPECT_TRUE(throwsSaying([&] { (void)sources::openSource((dir.path / "zero_tr").string()); },
                           {"calib.txt", "Tr", "orthonormal"}));
  writeKitti(dir.path / "nan", kIdentity34, {kIdentity34, "1 0 0 nan 0 1 0 0 0 0 1 0", kIdentity34});
  EXPECT_TRUE(
      throwsSaying([&] { (void)sources::openSource((dir.path / "nan").string()); }, {"line 2", "is nan"}));
  writeKitti(dir.path / "blank", kIdentity34, {kIdentity34, "", kIdentity34, kIdentity34});
  EXPECT_TRUE(
      throwsSaying([&] { (void)sources::openSource((dir.path / "blank").string()); }, {"line 2 is blank"}));
  writeKitti(dir.path / "short", kIdentity34, {kIdentity34, kIdentity34});
  EXPECT_TRUE(
      throwsSaying([&] { (void)sources::openSource((dir.path / "short").string()); }, {"2 poses", "scan 2"}));
}

TEST(SourceValidation, KittiGapIsAnErrorAndAllowedGapsKeepTheirPoseLines) {
  TempDir dir;
  const std::vector<std::string> poses = {kIdentity34, "1 0 0 1 0 1 0 0 0 0 1 0", "1 0 0 2 0 1 0 0 0 0 1 0",
                                          "1 0 0 3 0 1 0 0 0 0 1 0"};
  writeKitti(dir.path, kIdentity34, poses, {0, 1, 3});
  EXPECT_TRUE(throwsSaying([&] { (void)sources::openSource(dir.path.string()); },
                           {"scan 2 is missing", "--allow-gaps"}));
  sources::OpenOptions allow;
  allow.allow_gaps = true;
  const auto src = sources::openSource(dir.path.string(), allow);
  ASSERT_EQ(src->size(), 3u);
  EXPECT_EQ(src->read(2).pose.translation().x(), 3.0) << "velodyne/000003.bin is on pose line 3, not line 2";
  EXPECT_EQ(src->read(2).points[0].x(), 4.0f);
}

TEST(SourceValidation, KittiBinMustHoldWholeFiniteRecords) {
  EXPECT_TRUE(
      throwsSaying([] { parseKittiBin(std::string(20, '\0'), "0.bin"); }, {"0.bin", "16-byte records"}));
  const float rec[4] = {1, std::numeric_limits<float>::quiet_NaN(), 3, 0};
  EXPECT_TRUE(
      throwsSaying([&] { parseKittiBin(std::string(reinterpret_cast<const char*>(rec), 16), "0.bin"); },
                   {"point 0", "finite"}));
}

TEST(SourceValidation, NumberedNamesAndHugeIndices) {
  const auto n = parseNumberedName("sim_structured_12.pcd", ".pcd");
  ASSERT_TRUE(n.has_value());
  EXPECT_EQ(n->stem, "sim_structured_");
  EXPECT_EQ(n->number, 12u);
  EXPECT_FALSE(parseNumberedName("readme.txt", ".pcd").has_value());
  EXPECT_FALSE(parseNumberedName("scan_.pcd", ".pcd").has_value());
  EXPECT_EQ(parseNumberedName("000000000000000000000000007.bin", ".bin")->number, 7u);
  EXPECT_TRUE(throwsSaying([] { parseNumberedName("scan_99999999999999999999999.pcd", ".pcd"); },
                           {"scan_99999999999999999999999.pcd", "digits"}));
  TempDir dir;
  writePcd((dir.path / "scene_1.pcd").string(), {{1, 2, 3}});
  writePcd((dir.path / "scene_123456789012345678901234567890.pcd").string(), {{1, 2, 3}});
  EXPECT_TRUE(throwsSaying([&] { (void)sources::openSource(dir.path.string()); },
                           {"scene_123456789012345678901234567890", "digits"}));
  fs::remove(dir.path / "scene_123456789012345678901234567890.pcd");
  writePcd((dir.path / "other_2.pcd").string(), {{1, 2, 3}});
  EXPECT_TRUE(
      throwsSaying([&] { (void)sources::openSource(dir.path.string()); }, {"one sequence per directory"}));
}

}  // namespace
}  // namespace densemap::io
