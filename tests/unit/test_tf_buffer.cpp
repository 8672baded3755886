// The TF buffer: chains through the closest common ancestor, interpolation between stamps, waiting for
// transforms not yet arrived, and refusal of bad transforms (as tf2 refuses them).
#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "densemap/ros2/message_codec.h"
#include "densemap/ros2/sensor_pose.h"
#include "densemap/ros2/tf_buffer.h"

namespace densemap::ros2 {
namespace {

constexpr std::int64_t kSecond = 1'000'000'000;

TransformStamped transform(const std::string& parent, const std::string& child, std::int64_t stamp_ns,
                           Vector3 t, Quaternion q = {}) {
  TransformStamped out;
  out.header.frame_id = parent;
  out.header.stamp = Time::fromNanoseconds(stamp_ns);
  out.child_frame_id = child;
  out.translation = t;
  out.rotation = q;
  return out;
}

Quaternion yaw(double radians) { return {0, 0, std::sin(radians / 2), std::cos(radians / 2)}; }

TEST(TfBuffer, ComposesAStaticAndStampedChain) {
  TfBuffer tf;
  ASSERT_FALSE(tf.add(transform("map", "odom", 0, {10, 0, 0}), true));
  ASSERT_FALSE(tf.add(transform("odom", "base_link", 5 * kSecond, {1, 2, 0}, yaw(M_PI / 2)), false));
  ASSERT_FALSE(tf.add(transform("base_link", "velodyne", 0, {0.5, 0, 1.5}), true));
  const TfLookup r = tf.lookup("map", "velodyne", 5 * kSecond);
  ASSERT_EQ(r.status, TfLookup::Status::kOk) << r.reason;
  // velodyne origin: base (11, 2, 0) + yaw 90 deg applied to (0.5, 0, 1.5) = (11, 2.5, 1.5)
  EXPECT_NEAR((r.transform.translation() - Eigen::Vector3d(11, 2.5, 1.5)).norm(), 0, 1e-12);
  // And the inverse direction through the same ancestor.
  const TfLookup back = tf.lookup("velodyne", "map", 5 * kSecond);
  ASSERT_EQ(back.status, TfLookup::Status::kOk);
  EXPECT_TRUE((back.transform * r.transform).isApprox(Eigen::Isometry3d::Identity(), 1e-12));
}

TEST(TfBuffer, InterpolatesTranslationLinearlyAndRotationBySlerp) {
  TfBuffer tf;
  tf.add(transform("map", "base", 1 * kSecond, {0, 0, 0}, yaw(0)), false);
  tf.add(transform("map", "base", 2 * kSecond, {2, 4, 0}, yaw(M_PI / 2)), false);
  const TfLookup r = tf.lookup("map", "base", 1 * kSecond + kSecond / 4);
  ASSERT_EQ(r.status, TfLookup::Status::kOk);
  EXPECT_NEAR((r.transform.translation() - Eigen::Vector3d(0.5, 1, 0)).norm(), 0, 1e-12);
  const double angle = Eigen::AngleAxisd(r.transform.rotation()).angle();
  EXPECT_NEAR(angle, M_PI / 8, 1e-12);
}

TEST(TfBuffer, ATimeAfterTheNewestSampleIsNotYetAndBeforeTheOldestIsUnavailable) {
  TfBuffer tf;
  tf.add(transform("map", "base", 1 * kSecond, {0, 0, 0}), false);
  tf.add(transform("map", "base", 2 * kSecond, {1, 0, 0}), false);
  EXPECT_EQ(tf.lookup("map", "base", 3 * kSecond).status, TfLookup::Status::kNotYet);
  EXPECT_EQ(tf.lookup("map", "base", kSecond / 2).status, TfLookup::Status::kUnavailable);
  EXPECT_EQ(tf.lookup("map", "base", 2 * kSecond).status, TfLookup::Status::kOk);
  // An unknown frame may still arrive: wait.
  EXPECT_EQ(tf.lookup("map", "camera", 2 * kSecond).status, TfLookup::Status::kNotYet);
}

TEST(TfBuffer, TwoTreesAreUnavailable) {
  TfBuffer tf;
  tf.add(transform("map", "a", 0, {0, 0, 0}), true);
  tf.add(transform("world", "b", 0, {0, 0, 0}), true);
  const TfLookup r = tf.lookup("map", "b", 0);
  EXPECT_EQ(r.status, TfLookup::Status::kUnavailable);
  EXPECT_NE(r.reason.find("not connected"), std::string::npos);
}

TEST(TfBuffer, RefusesBadTransformsAndKeepsWhatItHad) {
  TfBuffer tf;
  tf.add(transform("map", "base", kSecond, {1, 0, 0}), false);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_TRUE(tf.add(transform("map", "base", 2 * kSecond, {nan, 0, 0}), false));
  EXPECT_TRUE(tf.add(transform("map", "base", 2 * kSecond, {0, 0, 0}, {0, 0, 0, 0}), false));
  EXPECT_TRUE(tf.add(transform("map", "base", 2 * kSecond, {0, 0, 0}, {0, 0, 0, 1.5}), false));
  EXPECT_TRUE(tf.add(transform("map", "map", 2 * kSecond, {0, 0, 0}), false));
  EXPECT_TRUE(tf.add(transform("", "base", 2 * kSecond, {0, 0, 0}), false));
  EXPECT_TRUE(tf.add(transform("base", "map", 2 * kSecond, {0, 0, 0}), false));  // a loop
  const TfLookup r = tf.lookup("map", "base", kSecond);
  ASSERT_EQ(r.status, TfLookup::Status::kOk);
  EXPECT_EQ(r.transform.translation(), Eigen::Vector3d(1, 0, 0));
  EXPECT_EQ(tf.lookup("map", "base", 2 * kSecond).status, TfLookup::Status::kNotYet);
}

TEST(TfBuffer, ForgetsSamplesOlderThanTheCacheWindow) {
  TfBuffer tf(10 * kSecond);
  for (int s = 0; s <= 30; ++s) tf.add(transform("map", "base", s * kSecond, {double(s), 0, 0}), false);
  EXPECT_EQ(tf.lookup("map", "base", 5 * kSecond).status, TfLookup::Status::kUnavailable);
  EXPECT_EQ(tf.lookup("map", "base", 25 * kSecond).status, TfLookup::Status::kOk);
}

TEST(TfBuffer, TfMessagesAndPoseTopicsFeedTheSameBuffer) {
  TfMessage m;
  m.transforms.push_back(transform("odom", "base_link", kSecond, {1, 0, 0}));
  m.transforms.push_back(transform("odom", "odom", kSecond, {1, 0, 0}));  // refused, the other kept
  TfBuffer tf;
  const auto refused = addTfMessage(tf, encode(m), false);
  EXPECT_EQ(refused.size(), 1u);
  EXPECT_EQ(tf.lookup("odom", "base_link", kSecond).status, TfLookup::Status::kOk);

  PoseStamped pose;
  pose.header.frame_id = "map";
  pose.header.stamp = Time::fromNanoseconds(kSecond);
  pose.position = {3, 4, 5};
  EXPECT_FALSE(addPoseMessage(tf, kPoseStampedType, encodePoseStamped(pose), "odom"));
  const TfLookup r = tf.lookup("map", "base_link", kSecond);
  ASSERT_EQ(r.status, TfLookup::Status::kOk);
  EXPECT_EQ(r.transform.translation(), Eigen::Vector3d(4, 4, 5));

  TfBuffer odom_tf;
  pose.child_frame_id = "base_link";
  EXPECT_FALSE(addPoseMessage(odom_tf, kOdometryType, encodeOdometry(pose), "unused"));
  EXPECT_EQ(odom_tf.lookup("map", "base_link", kSecond).status, TfLookup::Status::kOk);
  EXPECT_TRUE(addPoseMessage(odom_tf, "std_msgs/msg/String", encodeOdometry(pose), "x"));
}

}  // namespace
}  // namespace densemap::ros2
