// ROS 2 bags as sources: MCAP (chunks uncompressed, lz4, zstd, or none) and rosbag2 sqlite3 read the same
// messages; clouds get their poses from TF; damage is reported with the file and offset, never a crash.
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "densemap/io/lidar_simulator.h"
#include "densemap/ros2/bag_reader.h"
#include "densemap/ros2/bag_scan_source.h"
#include "densemap/ros2/mcap_reader.h"
#include "densemap/ros2/message_codec.h"
#include "densemap/ros2/point_cloud_fields.h"
#include "densemap/ros2/scan_messages.h"
#include "densemap/sources/open_source.h"
#include "mcap_writer.h"
#include "temp_dir.h"
#include "test_data.h"

using densemap::test::haveData;

namespace densemap::io {
namespace {

namespace fs = std::filesystem;

const std::string kMcap = "ros2/kitti00_0_19.mcap";
const std::string kSqlite = "ros2/kitti00_0_19";
const std::string kOs1 = "ros2/os1_indoor";

std::string data(const std::string& sub) { return test::dataDir() + "/" + sub; }

/// Every message of a bag as (topic name, log time, bytes).
struct Recorded {
  std::string topic;
  std::int64_t time;
  std::vector<std::uint8_t> bytes;
  bool operator==(const Recorded&) const = default;
};
std::vector<Recorded> everything(const ros2::BagReader& bag) {
  std::vector<Recorded> out;
  for (const auto& m : bag.messages())
    out.push_back({bag.topics()[m.topic].name, m.log_time_ns, bag.readMessage(m)});
  return out;
}

/// The messages of a reader re-recorded as MCAP with `compression`.
std::vector<std::uint8_t> rerecord(const ros2::BagReader& bag, const std::string& compression) {
  std::vector<test::McapChannel> channels;
  for (std::size_t i = 0; i < bag.topics().size(); ++i) {
    const auto& t = bag.topics()[i];
    channels.push_back({static_cast<std::uint16_t>(i + 1), t.name, t.type, t.offered_qos_profiles});
  }
  std::vector<test::McapMessage> messages;
  for (const auto& m : bag.messages())
    messages.push_back({static_cast<std::uint16_t>(m.topic + 1), static_cast<std::uint64_t>(m.log_time_ns),
                        bag.readMessage(m)});
  return test::McapWriter(compression).write(channels, messages);
}

std::string errorOf(std::vector<std::uint8_t> bytes) {
  try {
    ros2::McapReader r(std::move(bytes), "t.mcap");
    for (const auto& m : r.messages()) r.readMessage(m);
  } catch (const ros2::BagError& e) {
    return e.what();
  }
  return "";
}

TEST(RosBags, McapAndSqliteHoldTheSameMessages) {
  DENSEMAP_REQUIRE_DATA(kMcap);
  const auto mcap = ros2::openBag(data(kMcap));
  const auto sqlite = ros2::openBag(data(kSqlite));
  ASSERT_EQ(mcap->messages().size(), 60u);  // 20 clouds, 39 TF (every stamp and half-way), 1 static
  EXPECT_EQ(everything(*mcap), everything(*sqlite));
}

TEST(RosBags, EveryMcapChunkingReadsTheSameMessages) {
  DENSEMAP_REQUIRE_DATA(kMcap);
  const auto original = ros2::openBag(data(kMcap));
  const auto expected = everything(*original);
  for (const std::string compression : {"none", "", "lz4", "zstd"}) {
    ros2::McapReader r(rerecord(*original, compression), "rerecorded.mcap");
    EXPECT_EQ(everything(r), expected) << "chunks: '" << compression << "'";
    EXPECT_EQ(r.topics()[0].offered_qos_profiles, original->topics()[0].offered_qos_profiles);
  }
}

TEST(RosBags, KittiBagPosesComeFromTheTfChain) {
  DENSEMAP_REQUIRE_DATA(kMcap);
  DENSEMAP_REQUIRE_DATA("kitti00");
  ros2::BagScanSource bag(data(kMcap), {});
  const auto sequence = sources::openSource(data("kitti00"));
  ASSERT_EQ(bag.size(), 20u);
  for (std::size_t i = 0; i < bag.size(); ++i) {
    const Scan b = bag.read(i);
    const Scan s = sequence->read(i);
    // map -> odom -> base_link -> velodyne equals the pose file to ~5e-7 (the bag's README).
    EXPECT_LT((b.pose.matrix() - s.pose.matrix()).cwiseAbs().maxCoeff(), 1e-5) << "scan " << i;
    EXPECT_EQ(b.frame, PointFrame::kSensor);
    EXPECT_GT(b.points.size(), 100000u);
  }
}

TEST(RosBags, SqliteAndMcapGiveBitIdenticalScans) {
  DENSEMAP_REQUIRE_DATA(kMcap);
  ros2::BagScanSource mcap(data(kMcap), {});
  ros2::BagScanSource sqlite(data(kSqlite), {});
  ASSERT_EQ(mcap.size(), sqlite.size());
  for (std::size_t i = 0; i < mcap.size(); i += 7) {
    EXPECT_EQ(mcap.read(i).points, sqlite.read(i).points);
    EXPECT_TRUE(mcap.read(i).pose.matrix() == sqlite.read(i).pose.matrix());
  }
}

TEST(RosBags, Os1OrganisedCloudWithPaddedFieldsAndAStaticChain) {
  DENSEMAP_REQUIRE_DATA(kOs1);
  const auto bag = ros2::openBag(data(kOs1));
  std::size_t clouds = 0;
  for (const auto& m : bag->messages()) {
    if (bag->topics()[m.topic].type != ros2::kPointCloud2Type) continue;
    const auto bytes = bag->readMessage(m);
    const ros2::PointCloud2 c = ros2::decodePointCloud2(bytes);
    EXPECT_EQ(c.height, 64u);
    EXPECT_EQ(c.width, 2048u);
    EXPECT_EQ(c.point_step, 48u);
    const ros2::CloudPoints p = ros2::cloudPoints(c);
    EXPECT_EQ(p.points.size() + p.nonfinite_points, 64u * 2048u);
    ++clouds;
  }
  EXPECT_EQ(clouds, 2u);
  // Its TF tree is os1_sensor -> os1_lidar (static): no 'map', so the default frame is an error that says so.
  try {
    ros2::BagScanSource s(data(kOs1), {});
    ADD_FAILURE() << "opened without a map frame";
  } catch (const SourceError& e) {
    EXPECT_NE(std::string(e.what()).find("frame 'map' is not in the TF tree"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("--frame-id"), std::string::npos);
  }
  ros2::BagSourceOptions o;
  o.frames.fixed_frame = "os1_sensor";
  ros2::BagScanSource s(data(kOs1), o);
  ASSERT_EQ(s.size(), 2u);
  const Scan scan = s.read(0);
  EXPECT_GT(scan.points.size(), 50000u);
  // os1_sensor <- os1_lidar is a fixed mounting, the same for both scans.
  EXPECT_TRUE(scan.pose.matrix() == s.read(1).pose.matrix());
  EXPECT_FALSE(scan.pose.matrix().isIdentity());
}

TEST(RosBags, TheSimulatorRecordedAsABagReadsBackExactly) {
  // Needs no data: the simulator's scans as a ROS 2 robot publishes them, recorded as MCAP.
  LidarSimulator sim(LidarSimulatorOptions::parse("scans=4,beams=16,columns=256"));
  std::vector<test::McapMessage> messages;
  for (std::size_t i = 0; i < sim.size(); ++i) {
    const auto m = ros2::scanMessages(sim.read(i), 1'000'000'000 * std::int64_t(i + 1), "map", "lidar");
    const auto t = static_cast<std::uint64_t>(1'000'000'000 * (i + 1));
    messages.push_back({2, t, m.transform});
    messages.push_back({1, t + 1, m.cloud});
  }
  const auto bytes = test::McapWriter("zstd", 3).write(
      {{1, "/points", ros2::kPointCloud2Type, ""}, {2, "/tf", ros2::kTfMessageType, ""}}, messages);
  test::TempDir dir;
  const std::string path = dir.path.string() + "/sim.mcap";
  std::ofstream(path, std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
  const auto source = sources::openSource(path);
  ASSERT_EQ(source->size(), sim.size());
  for (std::size_t i = 0; i < sim.size(); ++i) {
    const Scan expected = sim.read(i);
    const Scan got = source->read(i);
    EXPECT_EQ(got.points, expected.sensorPoints());
    EXPECT_LT((got.pose.matrix() - expected.pose.matrix()).cwiseAbs().maxCoeff(), 1e-12);
  }
}

TEST(RosBags, RecordedBytesReEncodeIdentically) {
  // The bags were written by a third-party ROS 2 serializer: decoding and encoding again with densemap's
  // codec gives the recorded bytes back, every cloud and transform (the codec speaks ROS 2's CDR).
  for (const std::string& bag : {kMcap, kOs1}) {
    if (!haveData(bag)) GTEST_SKIP() << "no " << bag << " under " << test::dataDir();
    const auto reader = ros2::openBag(data(bag));
    std::size_t checked = 0;
    for (const auto& m : reader->messages()) {
      const std::string& type = reader->topics()[m.topic].type;
      const auto bytes = reader->readMessage(m);
      std::vector<std::uint8_t> again;
      if (type == ros2::kPointCloud2Type)
        again = ros2::encode(ros2::decodePointCloud2(bytes));
      else if (type == ros2::kTfMessageType)
        again = ros2::encode(ros2::decodeTfMessage(bytes));
      else
        continue;
      // A serializer may pad the sample's end to 4 bytes; what precedes must be identical.
      ASSERT_GE(bytes.size(), again.size());
      ASSERT_LT(bytes.size() - again.size(), 4u) << bag << " " << type;
      EXPECT_TRUE(std::equal(again.begin(), again.end(), bytes.begin())) << bag << " " << type;
      ++checked;
    }
    EXPECT_GT(checked, 2u);
  }
}

TEST(RosBags, ChoosingTheCloudTopic) {
  DENSEMAP_REQUIRE_DATA(kMcap);
  ros2::BagSourceOptions o;
  o.frames.cloud_topic = "/tf";
  EXPECT_THROW(ros2::BagScanSource(data(kMcap), o), SourceError);
  o.frames.cloud_topic = "/points";
  EXPECT_EQ(ros2::BagScanSource(data(kMcap), o).size(), 20u);
}

TEST(RosBagDamage, ATornMcapNamesTheOffset) {
  LidarSimulator sim(LidarSimulatorOptions::parse("scans=2,beams=8,columns=64"));
  const auto m = ros2::scanMessages(sim.read(0), 1, "map", "lidar");
  const auto bytes =
      test::McapWriter("zstd").write({{1, "/points", ros2::kPointCloud2Type, ""}}, {{1, 1, m.cloud}});
  ASSERT_EQ(errorOf(bytes), "");
  // Cut anywhere before the data end: an error that says where, never a crash (every byte is tried).
  std::size_t named_offsets = 0;
  for (std::size_t n = 0; n + 30 < bytes.size(); ++n) {
    const std::string e = errorOf({bytes.begin(), bytes.begin() + std::ptrdiff_t(n)});
    EXPECT_FALSE(e.empty()) << "cut at " << n;
    if (e.find("offset") != std::string::npos) ++named_offsets;
  }
  EXPECT_GT(named_offsets, bytes.size() / 2);
}

TEST(RosBagDamage, AFlippedBitInAChunkFailsItsCrc) {
  LidarSimulator sim(LidarSimulatorOptions::parse("scans=1,beams=8,columns=64"));
  const auto m = ros2::scanMessages(sim.read(0), 1, "map", "lidar");
  auto bytes = test::McapWriter("").write({{1, "/points", ros2::kPointCloud2Type, ""}}, {{1, 1, m.cloud}});
  bytes[bytes.size() - 200] ^= 0x10;  // inside the cloud's points
  EXPECT_NE(errorOf(bytes).find("CRC mismatch"), std::string::npos) << errorOf(bytes);
}

TEST(RosBagDamage, AHugeClaimedChunkIsRefusedBeforeAllocating) {
  LidarSimulator sim(LidarSimulatorOptions::parse("scans=1,beams=8,columns=64"));
  const auto m = ros2::scanMessages(sim.read(0), 1, "map", "lidar");
  auto bytes =
      test::McapWriter("zstd").write({{1, "/points", ros2::kPointCloud2Type, ""}}, {{1, 1, m.cloud}});
  // The first chunk record follows the magic, the header and the schema/channel records; find opcode 6.
  std::size_t pos = 8;
  while (bytes[pos] != 0x06) {
    std::uint64_t len;
    std::memcpy(&len, bytes.data() + pos + 1, 8);
    pos += 9 + len;
  }
  const std::uint64_t huge = 1ull << 40;
  std::memcpy(bytes.data() + pos + 9 + 16, &huge, 8);  // uncompressed_size
  EXPECT_NE(errorOf(bytes).find("refused"), std::string::npos) << errorOf(bytes);
}

TEST(RosBagDamage, NotAnMcapAndACorruptSqliteAreErrors) {
  EXPECT_NE(errorOf({'h', 'e', 'l', 'l', 'o', 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0}).find("not an MCAP"),
            std::string::npos);
  test::TempDir dir;
  const std::string db = dir.path.string() + "/broken.db3";
  std::ofstream(db) << "SQLite format 3 but not really a database, just text";
  EXPECT_THROW((void)sources::openSource(db), SourceError);
  const std::string bag = dir.path.string() + "/bag";
  fs::create_directory(bag);
  std::ofstream(bag + "/metadata.yaml") << "rosbag2_bagfile_information:\n  storage_identifier: sqlite3\n"
                                           "  relative_file_paths:\n    - ../../etc/passwd\n";
  try {
    (void)sources::openSource(bag);
    ADD_FAILURE() << "opened";
  } catch (const SourceError& e) {
    EXPECT_NE(std::string(e.what()).find("outside the bag's directory"), std::string::npos) << e.what();
  }
}

TEST(RosBagDamage, ATruncatedSqliteBagIsAnError) {
  DENSEMAP_REQUIRE_DATA(kSqlite);
  test::TempDir dir;
  const std::string db = dir.path.string() + "/cut.db3";
  fs::copy_file(data(kSqlite) + "/kitti00_0_19_0.db3", db);
  fs::resize_file(db, fs::file_size(db) / 3);
  EXPECT_THROW(
      {
        const auto s = sources::openSource(db);
        for (std::size_t i = 0; i < s->size(); ++i) s->read(i);
      },
      SourceError);
}

}  // namespace
}  // namespace densemap::io
