// Scan sources: the real datasets' layouts, a KITTI odometry layout written from kitti00, the simulator's
// exact geometry, and clear errors (naming the file) for corrupt or truncated input.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>

#include <unistd.h>

#include <gtest/gtest.h>

#include "densemap/io/kitti_odometry_source.h"
#include "densemap/io/lidar_simulator.h"
#include "densemap/io/scan_graph_source.h"
#include "densemap/io/scan_source.h"
#include "densemap/sources/open_source.h"
#include "temp_dir.h"
#include "test_data.h"

namespace densemap::io {
namespace {

namespace fs = std::filesystem;
using test::TempDir;

void expectErrorNaming(const std::function<void()>& f, const std::string& name) {
  try {
    f();
    ADD_FAILURE() << "no error for " << name;
  } catch (const SourceError& e) {
    EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
  }
}

TEST(Sources, SequenceDirectoryKitti) {
  DENSEMAP_REQUIRE_DATA("kitti00");
  auto src = sources::openSource(test::dataDir() + "/kitti00");
  EXPECT_EQ(src->size(), 60u);
  const Scan s0 = src->read(0);
  EXPECT_EQ(s0.points.size(), 124668u);
  EXPECT_EQ(s0.frame, PointFrame::kSensor);
  EXPECT_NEAR(s0.origin().norm(), 0.0, 1e-6);
  const Scan s5 = src->read(5);
  EXPECT_NEAR(s5.pose.translation().x(), 3.5514046906338166, 1e-12);
  for (const auto& p : s5.points) ASSERT_TRUE(p.allFinite());
}

TEST(Sources, SequenceDirectoryHilti) {
  DENSEMAP_REQUIRE_DATA("hilti2023");
  auto src = sources::openSource(test::dataDir() + "/hilti2023");
  EXPECT_EQ(src->size(), 30u);
  EXPECT_EQ(src->read(0).points.size(), 22096u);
}

TEST(Sources, La3dmViewpointPcd) {
  DENSEMAP_REQUIRE_DATA("la3dm/sim_structured");
  auto src = sources::openSource(test::dataDir() + "/la3dm/sim_structured");
  EXPECT_EQ(src->size(), 12u);
  const Scan s = src->read(0);
  EXPECT_EQ(s.frame, PointFrame::kWorld);
  EXPECT_EQ(s.points.size(), 3500u);
  EXPECT_FLOAT_EQ(s.origin().x(), 0.999982f);
  EXPECT_FLOAT_EQ(s.origin().z(), 0.0997627f);
  // Numbered files are read in numeric order (10 after 9, not after 1).
  EXPECT_EQ(src->read(9).points.size(), 3500u);
}

TEST(Sources, OctomapScanGraph) {
  DENSEMAP_REQUIRE_DATA("octomap/spherical_scan.graph");
  auto src = sources::openSource(test::dataDir() + "/octomap/spherical_scan.graph");
  ASSERT_EQ(src->size(), 1u);
  EXPECT_EQ(src->read(0).points.size(), 10201u);
}

TEST(Sources, KittiOdometryLayoutWrittenFromKitti00) {
  DENSEMAP_REQUIRE_DATA("kitti00");
  auto seq = sources::openSource(test::dataDir() + "/kitti00");
  TempDir dir;
  fs::create_directories(dir.path / "velodyne");
  // KITTI 00's velodyne -> camera calibration.
  Eigen::Isometry3d tr = Eigen::Isometry3d::Identity();
  tr.matrix().topRows<3>() << 4.276802385584e-04, -9.999672484946e-01, -8.084491683471e-03,
      -1.198459927713e-02, -7.210626507497e-03, 8.081198471645e-03, -9.999413164504e-01, -5.403984729748e-02,
      9.999738645903e-01, 4.859485810390e-04, -7.206933692422e-03, -2.921968648686e-01;
  {
    std::ofstream calib(dir.path / "calib.txt");
    calib.precision(17);
    calib << "P0: 1 0 0 0 0 1 0 0 0 0 1 0\nTr:";
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c) calib << ' ' << tr.matrix()(r, c);
    calib << '\n';
  }
  std::ofstream poses(dir.path / "poses.txt");
  poses.precision(17);
  std::vector<Scan> original;
  for (int i = 0; i < 3; ++i) {
    original.push_back(seq->read(static_cast<std::size_t>(i)));
    const Scan& s = original.back();
    char name[32];
    std::snprintf(name, sizeof name, "%06d.bin", i);
    std::ofstream bin(dir.path / "velodyne" / name, std::ios::binary);
    for (const auto& p : s.points) {
      const float v[4] = {p.x(), p.y(), p.z(), 0.5f};
      bin.write(reinterpret_cast<const char*>(v), sizeof v);
    }
    const Eigen::Matrix4d cam = (tr * s.pose * tr.inverse()).matrix();  // KITTI poses are camera poses
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c) poses << (r || c ? " " : "") << cam(r, c);
    poses << '\n';
  }
  poses.close();
  auto kitti = sources::openSource(dir.path.string());
  ASSERT_EQ(kitti->size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    const Scan s = kitti->read(i);
    ASSERT_EQ(s.points.size(), original[i].points.size());
    EXPECT_EQ(s.points[100], original[i].points[100]);
    // The data's rotations are orthonormal only to ~1e-7, and the Isometry inverse assumes orthonormality,
    // so the round trip through the calibration agrees to about that.
    EXPECT_TRUE(s.pose.isApprox(original[i].pose, 1e-6)) << "scan " << i << "\n"
                                                         << s.pose.matrix() << "\n"
                                                         << original[i].pose.matrix();
    EXPECT_TRUE(s.lidar.has_value());
  }
  // A truncated .bin names the file.
  fs::resize_file(dir.path / "velodyne" / "000001.bin", 1000 * 16 + 5);
  expectErrorNaming([&] { kitti->read(1); }, "000001.bin");
}

TEST(Sources, SimulatorIsDeterministicAndExact) {
  LidarSimulatorOptions o;
  o.scans = 2;
  o.lidar.rows = 16;
  o.lidar.columns = 360;
  o.scene.buildings_per_side = 0;
  o.scene.boxes = o.scene.poles = o.scene.trees = 0;  // ground plane only
  LidarSimulator sim(o);
  const Scan a = sim.read(1), b = sim.read(1);
  ASSERT_EQ(a.points, b.points);
  // Only beams below the horizon return, each exactly on the ground plane z = 0.
  int down = 0;
  for (int r = 0; r < 16; ++r) down += (2.0 - r * (2.0 + 24.9) / 15.0) < 0 ? 1 : 0;
  EXPECT_EQ(a.points.size(), static_cast<std::size_t>(down * 360));
  for (const auto& p : a.worldPoints()) EXPECT_NEAR(p.z(), 0.0f, 1e-4f);
  // Beam 15 (the lowest, -24.9 deg) hits at range h / sin(24.9 deg).
  const double expected = o.sensor_height / std::sin(24.9 * M_PI / 180.0);
  EXPECT_NEAR(a.points.back().norm(), expected, 1e-4);
  EXPECT_NEAR(a.origin().x(), o.start_x + o.speed, 1e-6);
}

TEST(Sources, SimulatorRendersOtherBeamCounts) {
  LidarSimulator sim;
  LidarGeometry g16 = sim.options().lidar;
  g16.rows = 16;
  const Scan s16 = sim.render(0, g16), s64 = sim.read(0);
  EXPECT_GT(s64.points.size(), 3 * s16.points.size());
  EXPECT_EQ(s16.lidar->rows, 16);
}

TEST(Sources, SimulatorSpecErrors) {
  EXPECT_THROW((void)sources::openSource("sim:beams=abc"), SourceError);
  EXPECT_THROW((void)sources::openSource("sim:colour=3"), SourceError);
  EXPECT_EQ(sources::openSource("sim:scans=3,beams=8")->size(), 3u);
}

TEST(Sources, CorruptFilesGiveErrorsNamingTheFile) {
  TempDir dir;
  // Truncated PCD.
  fs::create_directories(dir.path / "seq" / "clouds");
  fs::create_directories(dir.path / "seq" / "poses");
  {
    std::ofstream pcd(dir.path / "seq" / "clouds" / "0.pcd");
    pcd << "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 1000\nHEIGHT "
           "1\n"
           "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 1000\nDATA binary\n0123456789";
    std::ofstream pose(dir.path / "seq" / "poses" / "0.txt");
    pose << "1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n";
  }
  auto seq = sources::openSource((dir.path / "seq").string());
  expectErrorNaming([&] { seq->read(0); }, "0.pcd");
  // Bad pose file.
  {
    std::ofstream pcd(dir.path / "seq" / "clouds" / "1.pcd");
    pcd << "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 1\nHEIGHT 1\n"
           "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 1\nDATA ascii\n1 2 3\n";
    std::ofstream pose(dir.path / "seq" / "poses" / "1.txt");
    pose << "1 0 0 0\n0 1 0 nan_here\n";
  }
  auto seq2 = sources::openSource((dir.path / "seq").string());
  expectErrorNaming([&] { seq2->read(1); }, "1.txt");
  // Garbage scan graph: a huge node count.
  {
    std::ofstream g(dir.path / "bad.graph", std::ios::binary);
    const std::uint32_t nodes = 1000000;
    g.write(reinterpret_cast<const char*>(&nodes), 4);
    g << "garbage";
  }
  expectErrorNaming([&] { (void)sources::openSource((dir.path / "bad.graph").string()); }, "bad.graph");
  // Missing path.
  expectErrorNaming([&] { (void)sources::openSource((dir.path / "nope").string()); }, "nope");
}

TEST(Sources, TruncatedRealPcd) {
  DENSEMAP_REQUIRE_DATA("kitti00");
  TempDir dir;
  fs::create_directories(dir.path / "clouds");
  fs::create_directories(dir.path / "poses");
  fs::copy_file(test::dataDir() + "/kitti00/clouds/0.pcd", dir.path / "clouds" / "0.pcd");
  fs::copy_file(test::dataDir() + "/kitti00/poses/0.txt", dir.path / "poses" / "0.txt");
  fs::resize_file(dir.path / "clouds" / "0.pcd", fs::file_size(dir.path / "clouds" / "0.pcd") / 2);
  auto src = sources::openSource(dir.path.string());
  expectErrorNaming([&] { src->read(0); }, "0.pcd");
}

}  // namespace
}  // namespace densemap::io
