#include "densemap/ros2/bag_scan_source.h"

#include <limits>

#include <spdlog/spdlog.h>

#include "densemap/ros2/message_codec.h"
#include "densemap/ros2/point_cloud_fields.h"

namespace densemap::ros2 {

using io::PointFrame;
using io::poseFromQuaternion;
using io::Scan;
using io::SourceError;

BagScanSource::BagScanSource(const std::string& path, const BagSourceOptions& options) : path_(path) {
  try {
    bag_ = openBag(path);
  } catch (const BagError& e) {
    throw SourceError(e.what());
  }
  const FrameOptions& frames = options.frames;
  const auto& topics = bag_->topics();
  std::vector<std::string> cloud_topics;
  std::optional<std::size_t> cloud_topic, pose_topic;
  for (std::size_t i = 0; i < topics.size(); ++i) {
    if (topics[i].type == kPointCloud2Type) cloud_topics.push_back(topics[i].name);
    if (topics[i].name == frames.cloud_topic) cloud_topic = i;
    if (!frames.pose_topic.empty() && topics[i].name == frames.pose_topic) pose_topic = i;
  }
  auto list = [&] {
    std::string s;
    for (const auto& t : cloud_topics) s += (s.empty() ? "" : ", ") + t;
    return s.empty() ? std::string("none") : s;
  };
  if (frames.cloud_topic.empty()) {
    if (cloud_topics.size() != 1)
      throw SourceError(path + ": " + std::to_string(cloud_topics.size()) + " PointCloud2 topics (" + list() +
                        "); choose one with --cloud-topic");
    for (std::size_t i = 0; i < topics.size(); ++i)
      if (topics[i].name == cloud_topics.front()) cloud_topic = i;
  } else if (!cloud_topic || topics[*cloud_topic].type != kPointCloud2Type) {
    throw SourceError(path + ": no PointCloud2 topic '" + frames.cloud_topic +
                      "' (PointCloud2 topics: " + list() + ")");
  }
  topic_ = topics[*cloud_topic].name;
  if (!frames.pose_topic.empty() && (!pose_topic || !isPoseType(topics[*pose_topic].type)))
    throw SourceError(path + ": no Odometry or PoseStamped topic '" + frames.pose_topic + "'");

  // Every transform of the bag is known offline, so the buffer keeps them all (no cache window).
  TfBuffer tf(std::numeric_limits<std::int64_t>::max() / 4);
  std::size_t refused = 0;
  std::vector<BagMessageRef> clouds;
  for (const auto& m : bag_->messages()) {
    const std::string& name = topics[m.topic].name;
    try {
      if (m.topic == *cloud_topic) {
        clouds.push_back(m);
      } else if (!pose_topic && (name == kTfTopic || name == kTfStaticTopic) &&
                 topics[m.topic].type == kTfMessageType) {
        for (const auto& why : addTfMessage(tf, bag_->readMessage(m), name == kTfStaticTopic)) {
          spdlog::warn("{}: {} at {} ns: {}", path, name, m.log_time_ns, why);
          ++refused;
        }
      } else if (pose_topic && m.topic == *pose_topic) {
        if (auto why = addPoseMessage(tf, topics[m.topic].type, bag_->readMessage(m), frames.base_frame)) {
          spdlog::warn("{}: {} at {} ns: {}", path, name, m.log_time_ns, *why);
          ++refused;
        }
      }
    } catch (const DecodeError& e) {
      throw SourceError(path + ": message on " + name + " at " + std::to_string(m.log_time_ns) +
                        " ns: " + e.what());
    } catch (const BagError& e) {
      throw SourceError(e.what());
    }
  }
  // Static transforms need the whole bag read first, so poses are resolved after the pass.
  std::size_t without_pose = 0;
  for (std::size_t k = 0; k < clouds.size(); ++k) {
    PointCloud2 header;
    std::vector<std::uint8_t> bytes;
    try {
      bytes = bag_->readMessage(clouds[k]);
      header = decodePointCloud2(bytes);
    } catch (const std::runtime_error& e) {
      throw SourceError(path + ": cloud " + std::to_string(k) + " on " + topic_ + ": " + e.what());
    }
    const TfLookup pose =
        tf.lookup(frames.fixed_frame, header.header.frame_id, header.header.stamp.nanoseconds());
    if (pose.status != TfLookup::Status::kOk) {
      const std::string why = path + ": cloud " + std::to_string(k) + " (frame '" + header.header.frame_id +
                              "', stamp " + std::to_string(header.header.stamp.nanoseconds()) +
                              " ns) has no transform to '" + frames.fixed_frame + "': " + pose.reason;
      if (!options.allow_gaps)
        throw SourceError(why + " (set --frame-id, or --allow-gaps to leave such clouds out)");
      spdlog::warn("{}; left out (--allow-gaps)", why);
      ++without_pose;
      continue;
    }
    const SensorPose p = sensorPoseOf(pose.transform);
    clouds_.push_back({clouds[k], poseFromQuaternion(p.position, p.wxyz)});
  }
  if (refused) spdlog::warn("{}: {} transforms refused", path, refused);
  if (clouds_.empty())
    throw SourceError(path + ": no cloud on " + topic_ + " could be placed in '" + frames.fixed_frame + "'");
}

Scan BagScanSource::read(std::size_t i) const {
  if (i >= clouds_.size())
    throw SourceError(path_ + ": scan " + std::to_string(i) + " requested, the bag has " +
                      std::to_string(clouds_.size()));
  try {
    const std::vector<std::uint8_t> bytes = bag_->readMessage(clouds_[i].ref);
    CloudPoints cloud = cloudPoints(decodePointCloud2(bytes));
    Scan s;
    s.index = i;
    s.points = std::move(cloud.points);
    s.nonfinite_points = cloud.nonfinite_points;
    s.frame = PointFrame::kSensor;
    s.pose = clouds_[i].pose;
    return s;
  } catch (const std::runtime_error& e) {
    throw SourceError(path_ + ": cloud " + std::to_string(i) + " on " + topic_ + ": " + e.what());
  }
}

std::string BagScanSource::describe() const {
  return "ROS 2 bag " + path_ + ", " + std::to_string(clouds_.size()) + " clouds on " + topic_;
}

}  // namespace densemap::ros2
