// A robot: sends ten LiDAR scans to densemap-server and waits until the server has mapped them.
//   example-robot [DOMAIN]   (with densemap-server --domain DOMAIN --loopback running)
#include <cmath>
#include <cstdio>
#include <string>

#include "densemap/client/scan_publisher.h"

int main(int argc, char** argv) {
  using namespace densemap;
  msg::DdsOptions dds;
  dds.domain = argc > 1 ? std::stoi(argv[1]) : 0;
  dds.loopback = true;  // this host only; leave it false to reach a server on the network
  msg::DdsNode node(dds);
  client::ScanPublisher robot(node, {"robot-0"});
  if (!robot.waitForServer(std::chrono::seconds(30))) return std::puts("no densemap-server matched"), 1;
  for (std::uint64_t seq = 0; seq < 10; ++seq) {
    io::Scan scan;                    // points in the sensor frame, and the sensor's pose in the world
    for (int i = 0; i < 3600; ++i) {  // a ring of wall 6 m around the sensor
      const float a = 0.1f * float(i) * 3.14159265f / 180.f;
      scan.points.push_back({6.f * std::cos(a), 6.f * std::sin(a), 0.5f * float(i % 5) - 1.f});
    }
    scan.pose.translation() = Eigen::Vector3d(0.2 * double(seq), 0.0, 1.5);
    robot.publish("robot-0", seq, scan);
  }
  const client::AckCounts acks = robot.waitForAcks({"robot-0"}, 10, std::chrono::seconds(30));
  std::printf("10 scans sent, %llu mapped\n", static_cast<unsigned long long>(acks.applied));
  return acks.applied == 10 ? 0 : 1;
}
