// A TF buffer as tf2 keeps one: a tree of frames, each with its parent's transform, static or stamped; a
// lookup at a time composes the chain between two frames through their closest common ancestor,
// interpolating each stamped link (linear translation, slerp rotation) between the samples around it.
// The edge and the bag sources share it, so a bag mapped offline and the same bag played to the server
// get the same sensor poses.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <unordered_map>

#include <Eigen/Geometry>

#include "densemap/ros2/messages.h"

namespace densemap::ros2 {

struct TfLookup {
  enum class Status {
    kOk,
    kNotYet,       ///< a link's newest sample is older than the time: more TF may arrive (tf2's filter waits)
    kUnavailable,  ///< unknown or unconnected frames, or a time older than the buffer holds
  };
  Status status = Status::kUnavailable;
  Eigen::Isometry3d transform = Eigen::Isometry3d::Identity();  ///< target <- source
  std::string reason;
};

class TfBuffer {
 public:
  /// Stamped samples older than `cache_ns` behind a frame's newest are forgotten (tf2's default: 10 s).
  explicit TfBuffer(std::int64_t cache_ns = 10'000'000'000);

  /// Adds one transform; returns the reason when it is refused (empty or equal frame names, a
  /// non-finite value, a quaternion whose norm is not 1 within 1e-2 as tf2 requires, a parent that would
  /// make a loop). A frame's parent may change: its history then starts again (tf2 allows re-parenting).
  std::optional<std::string> add(const TransformStamped& transform, bool is_static);

  /// target <- source at `stamp_ns` (0: each link's newest, as tf2's time zero).
  TfLookup lookup(const std::string& target, const std::string& source, std::int64_t stamp_ns) const;

  bool hasFrame(const std::string& frame) const;
  std::size_t frameCount() const { return frames_.size(); }

 private:
  struct Sample {
    Eigen::Vector3d translation;
    Eigen::Quaterniond rotation;
  };
  struct Frame {
    std::string parent;
    bool is_static = false;
    Sample fixed;                            ///< static frames
    std::map<std::int64_t, Sample> history;  ///< stamped frames, by time
  };
  /// parent <- child at the time; nullopt with the status when it cannot be had.
  std::optional<Eigen::Isometry3d> link(const std::string& child, const Frame& frame, std::int64_t stamp_ns,
                                        TfLookup& failure) const;
  bool isAncestor(const std::string& maybe_ancestor, const std::string& frame) const;

  std::int64_t cache_ns_;
  std::unordered_map<std::string, Frame> frames_;
};

/// A message's rotation and translation as a rigid transform (quaternion normalised).
Eigen::Isometry3d toIsometry(const Vector3& translation, const Quaternion& rotation);

}  // namespace densemap::ros2
