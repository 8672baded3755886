// Writes seed inputs for the ROS 2 targets from the built-in simulator: a PointCloud2, TF and pose
// samples as a ROS 2 node sends them, and small MCAP files in every chunk compression.
//   make_ros2_seeds DIR
#include <filesystem>
#include <fstream>

#include "densemap/io/lidar_simulator.h"
#include "densemap/ros2/message_codec.h"
#include "densemap/ros2/scan_messages.h"
#include "mcap_writer.h"

namespace {
void write(const std::filesystem::path& dir, const std::string& name,
           const std::vector<std::uint8_t>& bytes) {
  std::filesystem::create_directories(dir);
  std::ofstream(dir / name, std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
}
}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) return 2;
  using namespace densemap;
  const std::filesystem::path root = argv[1];
  io::LidarSimulator sim(io::LidarSimulatorOptions::parse("scans=2,beams=4,columns=16"));
  const auto m0 = ros2::scanMessages(sim.read(0), 1'000'000'000, "map", "lidar");
  const auto m1 = ros2::scanMessages(sim.read(1), 2'000'000'000, "map", "lidar");
  write(root / "fuzz_ros2_point_cloud", "sim", m0.cloud);
  std::vector<std::uint8_t> tf{0};
  tf.insert(tf.end(), m0.transform.begin(), m0.transform.end());
  write(root / "fuzz_ros2_tf", "tf", tf);
  ros2::PoseStamped pose;
  pose.header.frame_id = "map";
  pose.position = {1, 2, 3};
  std::vector<std::uint8_t> odom{2}, stamped{3};
  const auto o = ros2::encodeOdometry(pose), p = ros2::encodePoseStamped(pose);
  odom.insert(odom.end(), o.begin(), o.end());
  stamped.insert(stamped.end(), p.begin(), p.end());
  write(root / "fuzz_ros2_tf", "odometry", odom);
  write(root / "fuzz_ros2_tf", "pose", stamped);
  for (const std::string compression : {"none", "", "lz4", "zstd"}) {
    const auto bytes =
        test::McapWriter(compression, 2)
            .write({{1, "/points", ros2::kPointCloud2Type, "- history: 1"},
                    {2, "/tf", ros2::kTfMessageType, ""}},
                   {{2, 1, m0.transform}, {1, 2, m0.cloud}, {2, 3, m1.transform}, {1, 4, m1.cloud}});
    write(root / "fuzz_mcap", "sim-" + (compression.empty() ? std::string("plain") : compression), bytes);
  }
  return 0;
}
