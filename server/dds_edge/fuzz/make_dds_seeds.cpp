// Writes seed inputs for the DDS decoder targets: each a sample serialized the way a DataWriter does.
//   make_dds_seeds DIR   (creates DIR/fuzz_dds_scan, DIR/fuzz_dds_query, DIR/fuzz_dds_admin)
#include <filesystem>
#include <fstream>
#include <string>

#include <fastdds/rtps/common/SerializedPayload.h>

#include "densemap/msg/wire_types.h"

namespace {
template <class PubSubType, class T>
void write(const std::filesystem::path& dir, const std::string& name, T& sample) {
  PubSubType type;
  eprosima::fastrtps::rtps::SerializedPayload_t payload(type.getSerializedSizeProvider(&sample)());
  if (!type.serialize(&sample, &payload)) throw std::runtime_error("serialize failed: " + name);
  std::filesystem::create_directories(dir);
  std::ofstream(dir / name, std::ios::binary)
      .write(reinterpret_cast<const char*>(payload.data), payload.length);
}
}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) return 2;
  const std::filesystem::path root = argv[1];
  using namespace densemap::msg;
  Scan scan;
  scan.robot_id("robot-0");
  scan.seq(7);
  scan.frame_id("sensor");
  scan.sensor_pose().qw(1.0);
  scan.sensor_pose().px(1.5);
  scan.points({1, 2, 3, -4, 5, 0.5f, 10, 0, 0});
  scan.lidar().rows(16);
  scan.lidar().columns(256);
  write<ScanPubSubType>(root / "fuzz_dds_scan", "scan", scan);
  QueryRequest q;
  q.client_id("client");
  q.request_id(3);
  q.points({1, 2, 3, 0, 0, 0});
  write<QueryRequestPubSubType>(root / "fuzz_dds_query", "points", q);
  q.kind(QUERY_BOX);
  q.box_min({-1, -1, -1});
  q.box_max({1, 1, 1});
  q.limit(10);
  write<QueryRequestPubSubType>(root / "fuzz_dds_query", "box", q);
  q.kind(QUERY_RAY);
  q.ray_direction({1, 0, 0});
  q.max_range(20);
  q.layer(LAYER_DENSE);
  write<QueryRequestPubSubType>(root / "fuzz_dds_query", "ray", q);
  AdminRequest a;
  a.client_id("admin");
  a.request_id(9);
  a.kind(ADMIN_SAVE);
  a.name("map-1");
  write<AdminRequestPubSubType>(root / "fuzz_dds_admin", "save", a);
  a.kind(ADMIN_CLEAR_BOX);
  a.box_min({-1, -1, -1});
  a.box_max({1, 1, 1});
  write<AdminRequestPubSubType>(root / "fuzz_dds_admin", "clear_box", a);
  ServerStatistics st;
  st.server_id("densemap-server");
  st.stamp_ns(1'764'000'000'000'000'000);
  st.uptime_s(12.5);
  st.robots().resize(1);
  st.robots()[0].robot_id("robot-0");
  write<ServerStatisticsPubSubType>(root / "fuzz_dds_statistics", "statistics", st);
  return 0;
}
