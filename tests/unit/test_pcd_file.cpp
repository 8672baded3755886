// The PCD parser (core/io/src/pcd_file.cpp): files PCL writes in each of its encodings read exactly as PCL
// reads them, the real data's PCDs too, and every hostile file is an error that names the file
// and the field instead of a crash, an allocation of what the header claims, or points at (0,0,0).
#include <sys/resource.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>

#include <gtest/gtest.h>
#include <pcl/io/pcd_io.h>
#include <pcl/point_types.h>

#include "densemap/io/pcd_file.h"
#include "test_data.h"

namespace densemap::io {
namespace {

namespace fs = std::filesystem;

std::string header(const std::string& fields, const std::string& size, const std::string& type,
                   const std::string& count, std::size_t points, const std::string& data = "binary",
                   const std::string& viewpoint = "0 0 0 1 0 0 0") {
  return "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS " + fields + "\nSIZE " + size +
         "\nTYPE " + type + "\nCOUNT " + count + "\nWIDTH " + std::to_string(points) +
         "\nHEIGHT 1\nVIEWPOINT " + viewpoint + "\nPOINTS " + std::to_string(points) + "\nDATA " + data +
         "\n";
}

template <class T>
std::string bytesOf(std::initializer_list<T> values) {
  std::string out(values.size() * sizeof(T), '\0');
  std::memcpy(out.data(), std::data(values), out.size());
  return out;
}

/// The error parsePcd gives, or "" when it parses.
std::string errorOf(const std::string& bytes) {
  try {
    parsePcd(bytes, "test.pcd");
  } catch (const SourceError& e) {
    return e.what();
  }
  return "";
}

::testing::AssertionResult rejects(const std::string& bytes, const std::string& says) {
  const std::string e = errorOf(bytes);
  if (e.empty()) return ::testing::AssertionFailure() << "parsed without an error";
  if (e.rfind("test.pcd: ", 0) != 0)
    return ::testing::AssertionFailure() << "error does not name the file: " << e;
  if (e.find(says) == std::string::npos)
    return ::testing::AssertionFailure() << "error '" << e << "' lacks '" << says << "'";
  return ::testing::AssertionSuccess();
}

const std::string kXyz = header("x y z", "4 4 4", "F F F", "1 1 1", 2);
const std::string kTwoPoints = bytesOf<float>({1, 2, 3, 4, 5, 6});

TEST(PcdFile, ReadsFloat32Binary) {
  const PcdData d = parsePcd(kXyz + kTwoPoints, "test.pcd");
  ASSERT_EQ(d.points.size(), 2u);
  EXPECT_EQ(d.points[1], Vec3f(4, 5, 6));
}

TEST(PcdFile, ZeroByteFileIsAnError) { EXPECT_TRUE(rejects("", "empty")); }

TEST(PcdFile, NegativeCountIsAnError) {
  EXPECT_TRUE(rejects(header("x y z", "4 4 4", "F F F", "-1 1 1", 1) + bytesOf<float>({1, 2, 3}),
                      "COUNT of field 'x'"));
}

TEST(PcdFile, Float64CoordinatesAreReadNotZeroed) {
  const PcdData d = parsePcd(
      header("x y z", "8 8 8", "F F F", "1 1 1", 2) + bytesOf<double>({1.5, -2.25, 3, 4, 5, 6e3}), "t");
  ASSERT_EQ(d.points.size(), 2u);
  EXPECT_EQ(d.points[0], Vec3f(1.5f, -2.25f, 3.0f));
  EXPECT_EQ(d.points[1], Vec3f(4.0f, 5.0f, 6e3f));
}

TEST(PcdFile, IntegerOrOddSizedCoordinatesAreRejectedNotZeroFilled) {
  EXPECT_TRUE(
      rejects(header("x y z", "4 4 4", "U U U", "1 1 1", 1) + bytesOf<std::uint32_t>({1, 2, 3}), "TYPE U"));
  EXPECT_TRUE(
      rejects(header("x y z", "2 2 2", "I I I", "1 1 1", 1) + bytesOf<std::int16_t>({1, 2, 3}), "TYPE I"));
  EXPECT_TRUE(rejects(header("x y z", "3 3 3", "F F F", "1 1 1", 1) + std::string(9, '\0'),
                      "SIZE of field 'x' is 3"));
  EXPECT_TRUE(rejects(header("x y z", "4 4 4", "F F F", "2 1 1", 1) + std::string(16, '\0'), "COUNT 2"));
  EXPECT_TRUE(rejects(header("x y", "4 4", "F F", "1 1", 1) + std::string(8, '\0'), "no 'z'"));
}

TEST(PcdFile, EveryCutInsideTheHeaderIsAnError) {
  for (std::size_t n = 1; n < kXyz.size(); ++n) {
    const std::string e = errorOf(kXyz.substr(0, n));
    EXPECT_FALSE(e.empty()) << "a header cut after " << n << " bytes parsed as a scan";
  }
}

TEST(PcdFile, NonFiniteViewpointIsAnError) {
  EXPECT_TRUE(rejects(header("x y z", "4 4 4", "F F F", "1 1 1", 2, "binary", "nan 0 0 1 0 0 0") + kTwoPoints,
                      "VIEWPOINT"));
  EXPECT_TRUE(rejects(header("x y z", "4 4 4", "F F F", "1 1 1", 2, "binary", "0 0 0 2 0 0 0") + kTwoPoints,
                      "unit quaternion"));
}

TEST(PcdFile, AsciiReadsNumbersAndRejectsGarbage) {
  const std::string h = header("x y z", "4 4 4", "F F F", "1 1 1", 3, "ascii");
  const PcdData d = parsePcd(h + "1 2 3\nnan nan nan\n4 5 6\n", "t");
  ASSERT_EQ(d.points.size(), 2u);
  EXPECT_EQ(d.nonfinite_points, 1u);
  EXPECT_EQ(d.points[1], Vec3f(4, 5, 6));
  EXPECT_TRUE(rejects(h + "1 2 3\nhello world foo\n4 5 6\n", "line 2"));
  EXPECT_TRUE(rejects(h + "1 2 3\n4 5\n6 7 8\n", "has 2 values"));
  EXPECT_TRUE(rejects(h + "1 2 3\n4 5 6\n", "has 2 points"));
  EXPECT_TRUE(rejects(h + "1 2 3\n4 5 6\n7 8 9\n1 1 1\n", "past the 3 POINTS"));
  EXPECT_TRUE(rejects(h + "1 2 3\n4 5 6\n7 8 9x\n", "'9x'"));
}

TEST(PcdFile, HugeClaimedPointCountFailsWithoutAllocatingIt) {
  rusage before{}, after{};
  getrusage(RUSAGE_SELF, &before);
  EXPECT_TRUE(
      rejects(header("x y z", "4 4 4", "F F F", "1 1 1", std::size_t{1} << 28) + kTwoPoints, "truncated"));
  EXPECT_TRUE(rejects(header("x y z", "4 4 4", "F F F", "1 1 1", std::size_t{1} << 28, "ascii") + "1 2 3\n",
                      "cannot fit"));
  getrusage(RUSAGE_SELF, &after);
  EXPECT_LT(after.ru_maxrss - before.ru_maxrss, 64 * 1024) << "KB of peak memory for a 1 KB file";
}

TEST(PcdFile, TrailingZeroPaddingIsAcceptedOtherBytesAreNot) {
  EXPECT_EQ(parsePcd(kXyz + kTwoPoints + std::string(100, '\0'), "t").points.size(), 2u);
  EXPECT_TRUE(rejects(kXyz + kTwoPoints + "junk", "not zero padding"));
  EXPECT_TRUE(rejects(kXyz + kTwoPoints.substr(0, 23), "truncated"));
}

TEST(PcdFile, MalformedHeadersAreErrors) {
  EXPECT_TRUE(rejects("VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nPOINTS 2\nDATA binary\n" +
                          kTwoPoints.substr(0, 12),
                      "POINTS 2 differs"));
  EXPECT_TRUE(
      rejects("VERSION 0.7\nFIELDS x y z\nSIZE 4 4\nTYPE F F F\nWIDTH 1\nDATA binary\n", "SIZE has 2"));
  EXPECT_TRUE(
      rejects("VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nDATA lzma\n", "DATA 'lzma'"));
  EXPECT_TRUE(rejects("VERSION 0.7\nBOGUS 1\n", "unknown header line"));
  EXPECT_TRUE(rejects(std::string("\x7f"
                                  "ELF\x02\x01",
                                  6),
                      "not text"));
  EXPECT_TRUE(
      rejects(header("x y z x", "4 4 4 4", "F F F F", "1 1 1 1", 1) + std::string(16, '\0'), "twice"));
}

TEST(PcdFile, CorruptCompressedDataIsAnError) {
  pcl::PointCloud<pcl::PointXYZ> cloud;
  for (int i = 0; i < 500; ++i) cloud.push_back(pcl::PointXYZ(0.1f * i, 1.0f, -2.0f));
  const fs::path path = fs::temp_directory_path() / ("densemap_pcd_" + std::to_string(::getpid()) + ".pcd");
  ASSERT_EQ(pcl::io::savePCDFileBinaryCompressed(path.string(), cloud), 0);
  std::ifstream in(path, std::ios::binary);
  const std::string good((std::istreambuf_iterator<char>(in)), {});
  fs::remove(path);
  ASSERT_EQ(parsePcd(good, "t").points.size(), 500u);
  const std::size_t data = good.find("DATA binary_compressed\n") + 23;
  std::string claims_more = good;
  const std::uint32_t big = 1u << 30;
  std::memcpy(claims_more.data() + data + 4, &big, 4);
  EXPECT_TRUE(rejects(claims_more, "uncompressed"));
  std::string cut = good.substr(0, good.size() - 10);
  EXPECT_TRUE(rejects(cut, "truncated"));
  std::mt19937 rng(7);
  int corrupt_rejected = 0;
  for (int trial = 0; trial < 200; ++trial) {
    std::string bad = good;
    const std::size_t at = data + 8 + rng() % (good.size() - data - 8);
    bad[at] = static_cast<char>(bad[at] ^ (1 + rng() % 255));
    // A flipped byte either breaks the LZF stream (an error) or changes a value; never a crash.
    corrupt_rejected += errorOf(bad).empty() ? 0 : 1;
  }
  EXPECT_GT(corrupt_rejected, 0);
}

template <class Point>
void expectSameAsPcl(const pcl::PointCloud<Point>& cloud, const std::string& encoding) {
  const fs::path path =
      fs::temp_directory_path() / ("densemap_pcd_" + std::to_string(::getpid()) + encoding + ".pcd");
  pcl::PCDWriter writer;
  int rc = -1;
  if (encoding == "ascii") rc = writer.writeASCII(path.string(), cloud, 9);
  if (encoding == "binary") rc = writer.writeBinary(path.string(), cloud);
  if (encoding == "binary_compressed") rc = writer.writeBinaryCompressed(path.string(), cloud);
  ASSERT_EQ(rc, 0);
  const PcdData d = readPcd(path.string());
  fs::remove(path);
  std::size_t finite = 0;
  for (const auto& p : cloud.points) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) continue;
    ASSERT_LT(finite, d.points.size()) << encoding;
    EXPECT_EQ(d.points[finite], Vec3f(p.x, p.y, p.z)) << encoding << " point " << finite;
    ++finite;
  }
  EXPECT_EQ(d.points.size(), finite) << encoding;
  EXPECT_EQ(d.nonfinite_points, cloud.size() - finite) << encoding;
  EXPECT_NEAR((d.viewpoint - Eigen::Vector3d(1.5, -2, 0.25)).norm(), 0.0, 1e-6) << encoding;
}

TEST(PcdFile, EveryEncodingPclWritesReadsAsPclWroteIt) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-50.0f, 50.0f);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  pcl::PointCloud<pcl::PointXYZI> organised(64, 16);  // organised: NaN marks a missing return
  pcl::PointCloud<pcl::PointXYZRGBNormal> padded;     // extra fields and padding between them
  for (auto& p : organised.points) p = pcl::PointXYZI(u(rng), u(rng), u(rng), u(rng));
  for (std::size_t i = 0; i < organised.size(); i += 7) organised.points[i].x = nan;
  for (int i = 0; i < 300; ++i) {
    pcl::PointXYZRGBNormal p;
    p.x = u(rng), p.y = u(rng), p.z = u(rng), p.normal_x = 1, p.curvature = 0.5f;
    padded.push_back(p);
  }
  for (auto* c : {&organised.sensor_origin_, &padded.sensor_origin_})
    *c = Eigen::Vector4f(1.5f, -2, 0.25f, 0);
  for (const std::string e : {"ascii", "binary", "binary_compressed"}) {
    expectSameAsPcl(organised, e);
    expectSameAsPcl(padded, e);
  }
}

TEST(PcdFile, WritePcdRoundTrips) {
  const fs::path path =
      fs::temp_directory_path() / ("densemap_pcd_rt_" + std::to_string(::getpid()) + ".pcd");
  const std::vector<Vec3f> pts = {{1, 2, 3}, {-0.1f, 1e-7f, 3e5f}};
  writePcd(path.string(), pts, Eigen::Vector3d(0.1, 0.2, 1.0 / 3.0));
  const PcdData d = readPcd(path.string());
  fs::remove(path);
  EXPECT_EQ(d.points, pts);
  EXPECT_EQ(d.viewpoint, Eigen::Vector3d(0.1, 0.2, 1.0 / 3.0));
}

TEST(PcdFile, RealDataReadsAsPclReadsIt) {
  DENSEMAP_REQUIRE_DATA("kitti00");
  std::size_t files = 0;
  for (const auto& e : fs::recursive_directory_iterator(test::dataDir())) {
    if (e.path().extension() != ".pcd") continue;
    pcl::PointCloud<pcl::PointXYZ> cloud;
    ASSERT_EQ(pcl::io::loadPCDFile(e.path().string(), cloud), 0) << e.path();
    const PcdData d = readPcd(e.path().string());
    std::size_t k = 0;
    for (const auto& p : cloud.points) {
      if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) continue;
      ASSERT_EQ(d.points.at(k), Vec3f(p.x, p.y, p.z)) << e.path() << " point " << k;
      ++k;
    }
    ASSERT_EQ(d.points.size(), k) << e.path();
    EXPECT_NEAR((d.viewpoint.cast<float>() - cloud.sensor_origin_.head<3>()).norm(), 0.0f, 1e-6f) << e.path();
    ++files;
  }
  EXPECT_GT(files, 100u);
}

}  // namespace
}  // namespace densemap::io
