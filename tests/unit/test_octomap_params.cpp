// An octomap_server parameters file applied to densemap's options: nested and flat names, the node's
// section over the wildcard, flags winning, unimplemented parameters named, wrong types refused.
#include <gtest/gtest.h>

#include "densemap/server/ros2_edge/octomap_params.h"

namespace densemap::server::ros2_edge {
namespace {

struct Config {
  map::MapOptions map;
  update::UpdateOptions update;
  Ros2EdgeOptions ros2;
  OctomapParamTargets targets() { return {&map, &update, &ros2}; }
};

const auto kNoFlags = [](const std::string&) { return false; };

// As octomap_server's own example configuration lays it out (ROS 2 YAML, nested sensor_model).
const char* kFile = R"(
/**:
  ros__parameters:
    use_sim_time: false
    resolution: 0.5
octomap_server:
  ros__parameters:
    resolution: 0.1
    frame_id: odom
    base_frame_id: base_link
    latch: true
    occupancy_min_z: 0.05
    occupancy_max_z: 1.5
    pointcloud_min_z: -0.5
    point_cloud_max_z: 2.0
    filter_ground: true
    sensor_model:
      max_range: 15.0
      hit: 0.75
      miss: 0.35
      min: 0.1
      max: 0.95
)";

TEST(OctomapParams, SetsEveryParameterItKnows) {
  Config c;
  const auto ignored = applyOctomapParamsText(kFile, "p.yaml", "octomap_server", c.targets(), kNoFlags);
  EXPECT_DOUBLE_EQ(c.map.resolution, 0.1);  // the node's section wins over /**
  EXPECT_EQ(c.ros2.frames.fixed_frame, "odom");
  EXPECT_EQ(c.ros2.frames.base_frame, "base_link");
  EXPECT_TRUE(c.ros2.latch);
  EXPECT_DOUBLE_EQ(c.ros2.occupancy_min_z, 0.05);
  EXPECT_DOUBLE_EQ(c.ros2.occupancy_max_z, 1.5);
  EXPECT_DOUBLE_EQ(c.ros2.pointcloud_min_z, -0.5);
  EXPECT_DOUBLE_EQ(c.ros2.pointcloud_max_z, 2.0);
  EXPECT_DOUBLE_EQ(c.update.max_range, 15.0);
  EXPECT_DOUBLE_EQ(c.map.params.prob_hit, 0.75);
  EXPECT_DOUBLE_EQ(c.map.params.prob_miss, 0.35);
  EXPECT_DOUBLE_EQ(c.map.params.clamp_min, 0.1);
  EXPECT_DOUBLE_EQ(c.map.params.clamp_max, 0.95);
  ASSERT_EQ(ignored.size(), 1u);
  EXPECT_NE(ignored[0].find("filter_ground"), std::string::npos);
}

TEST(OctomapParams, FlagsOnTheCommandLineWin) {
  Config c;
  c.map.resolution = 0.3;
  applyOctomapParamsText(kFile, "p.yaml", "octomap_server", c.targets(),
                         [](const std::string& flag) { return flag == "resolution"; });
  EXPECT_DOUBLE_EQ(c.map.resolution, 0.3);
  EXPECT_EQ(c.ros2.frames.fixed_frame, "odom");
}

TEST(OctomapParams, RosOneSlashNamesAndALeadingSlashNodeName) {
  Config c;
  applyOctomapParamsText("/octomap_server:\n  ros__parameters:\n    sensor_model/max_range: 4.0\n", "p.yaml",
                         "octomap_server", c.targets(), kNoFlags);
  EXPECT_DOUBLE_EQ(c.update.max_range, 4.0);
}

TEST(OctomapParams, WrongTypesAndMissingSectionsAreErrorsThatSayWhat) {
  Config c;
  try {
    applyOctomapParamsText("octomap_server:\n  ros__parameters:\n    frame_id: odom\n    resolution: fine\n",
                           "p.yaml", "octomap_server", c.targets(), kNoFlags);
    ADD_FAILURE() << "accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("p.yaml: parameter resolution = 'fine' is not a number"),
              std::string::npos)
        << e.what();
  }
  EXPECT_THROW(applyOctomapParamsText("other_node:\n  ros__parameters: {}\n", "p.yaml", "octomap_server",
                                      c.targets(), kNoFlags),
               std::invalid_argument);
  EXPECT_THROW(applyOctomapParamsText("[1, 2", "p.yaml", "octomap_server", c.targets(), kNoFlags),
               std::invalid_argument);
  EXPECT_THROW(
      applyOctomapParamsText("octomap_server: 3\n", "p.yaml", "octomap_server", c.targets(), kNoFlags),
      std::invalid_argument);
  EXPECT_DOUBLE_EQ(c.map.resolution, 0.2);  // nothing applied from a file with a wrong value
  EXPECT_EQ(c.ros2.frames.fixed_frame, "map");
}

TEST(OctomapParams, AMissingFileIsAnError) {
  Config c;
  EXPECT_THROW(applyOctomapParams("/nonexistent/params.yaml", "octomap_server", c.targets(), kNoFlags),
               std::invalid_argument);
}

}  // namespace
}  // namespace densemap::server::ros2_edge
