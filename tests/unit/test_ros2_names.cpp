// ROS 2 names and QoS as rmw_fastrtps puts them on DDS.
#include <gtest/gtest.h>

#include "densemap/ros2/names.h"
#include "densemap/ros2/qos.h"

namespace densemap::ros2 {
namespace {

TEST(Ros2Names, TopicsServicesAndTypesAsRmwFastrtpsNamesThem) {
  EXPECT_EQ(topicOnDds(resolveName("/cloud_in", "octomap_server")), "rt/cloud_in");
  EXPECT_EQ(topicOnDds(resolveName("cloud_in", "octomap_server")), "rt/cloud_in");
  EXPECT_EQ(topicOnDds(resolveName("points", "n", "/robot1")), "rt/robot1/points");
  const std::string clear = resolveName("~/clear_bbox", "octomap_server");
  EXPECT_EQ(clear, "/octomap_server/clear_bbox");
  EXPECT_EQ(requestTopicOnDds(clear), "rq/octomap_server/clear_bboxRequest");
  EXPECT_EQ(replyTopicOnDds(clear), "rr/octomap_server/clear_bboxReply");
  EXPECT_EQ(typeOnDds("sensor_msgs/msg/PointCloud2"), "sensor_msgs::msg::dds_::PointCloud2_");
  EXPECT_EQ(requestTypeOnDds("octomap_msgs/srv/BoundingBoxQuery"),
            "octomap_msgs::srv::dds_::BoundingBoxQuery_Request_");
  EXPECT_EQ(responseTypeOnDds("std_srvs/srv/Empty"), "std_srvs::srv::dds_::Empty_Response_");
}

TEST(Ros2Names, NamesRos2RefusesAreRefused) {
  for (const char* bad : {"", "/", "/a//b", "/a/", "/1abc", "/a b", "/a-b"})
    EXPECT_THROW(resolveName(bad, "node"), std::invalid_argument) << bad;
  EXPECT_THROW(typeOnDds("sensor_msgs/PointCloud2"), std::invalid_argument);
  EXPECT_THROW(requestTypeOnDds("std_srvs/msg/Empty"), std::invalid_argument);
}

TEST(Ros2Qos, RecordedProfilesReadAsRosbag2WritesThem) {
  // As in the kitti00 bag's metadata: /points best effort volatile depth 5, /tf_static transient local.
  const auto points = parseOfferedQos("- history: 1\n  depth: 5\n  reliability: 2\n  durability: 2\n");
  ASSERT_TRUE(points);
  EXPECT_FALSE(points->reliable);
  EXPECT_FALSE(points->transient_local);
  EXPECT_EQ(points->depth, 5u);
  const auto latched = parseOfferedQos("- history: 3\n  depth: 0\n  reliability: 1\n  durability: 1\n");
  ASSERT_TRUE(latched);
  EXPECT_TRUE(latched->reliable);
  EXPECT_TRUE(latched->transient_local);
  EXPECT_EQ(latched->depth, 1u);
  EXPECT_FALSE(parseOfferedQos(""));
  EXPECT_THROW(parseOfferedQos("- depth: [unclosed"), std::invalid_argument);
}

}  // namespace
}  // namespace densemap::ros2
