#include "densemap/ros2/tf_buffer.h"

#include <cmath>
#include <vector>

namespace densemap::ros2 {

namespace {

// A hostile publisher could send millions of stamps inside the cache window; tf2 bounds time, we also
// bound count so memory stays bounded (10 s at 1 kHz).
constexpr std::size_t kMaxSamplesPerFrame = 10'000;
// The longest chain followed; deeper trees are refused rather than walked forever.
constexpr int kMaxDepth = 64;

bool finite(const Vector3& v) { return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]); }

}  // namespace

Eigen::Isometry3d toIsometry(const Vector3& translation, const Quaternion& rotation) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() =
      Eigen::Quaterniond(rotation.w, rotation.x, rotation.y, rotation.z).normalized().toRotationMatrix();
  t.translation() = Eigen::Vector3d(translation[0], translation[1], translation[2]);
  return t;
}

TfBuffer::TfBuffer(std::int64_t cache_ns) : cache_ns_(cache_ns) {}

bool TfBuffer::hasFrame(const std::string& frame) const {
  if (frames_.count(frame)) return true;
  for (const auto& [child, f] : frames_)
    if (f.parent == frame) return true;
  return false;
}

bool TfBuffer::isAncestor(const std::string& maybe_ancestor, const std::string& frame) const {
  std::string at = frame;
  for (int depth = 0; depth <= kMaxDepth; ++depth) {
    if (at == maybe_ancestor) return true;
    auto it = frames_.find(at);
    if (it == frames_.end()) return false;
    at = it->second.parent;
  }
  return true;  // deeper than we follow: treat as a loop
}

std::optional<std::string> TfBuffer::add(const TransformStamped& t, bool is_static) {
  const std::string& parent = t.header.frame_id;
  const std::string& child = t.child_frame_id;
  if (parent.empty() || child.empty()) return "a transform with an empty frame name";
  if (parent == child) return "a transform from frame '" + child + "' to itself";
  const Quaternion& q = t.rotation;
  if (!finite(t.translation) || !std::isfinite(q.x) || !std::isfinite(q.y) || !std::isfinite(q.z) ||
      !std::isfinite(q.w))
    return "transform " + parent + " <- " + child + " holds NaN or Inf";
  const double norm = std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w);
  if (std::abs(norm - 1.0) > 1e-2)
    return "transform " + parent + " <- " + child + " has a quaternion of norm " + std::to_string(norm) +
           " (tf2 requires 1 within 1e-2)";
  if (isAncestor(child, parent))
    return "transform " + parent + " <- " + child + " would make a loop in the TF tree";

  Frame& frame = frames_[child];
  if (frame.parent != parent || frame.is_static != is_static) {
    frame = Frame{};
    frame.parent = parent;
    frame.is_static = is_static;
  }
  const Sample sample{Eigen::Vector3d(t.translation[0], t.translation[1], t.translation[2]),
                      Eigen::Quaterniond(q.w, q.x, q.y, q.z).normalized()};
  if (is_static) {
    frame.fixed = sample;
    return std::nullopt;
  }
  const std::int64_t stamp = t.header.stamp.nanoseconds();
  frame.history[stamp] = sample;
  const std::int64_t newest = frame.history.rbegin()->first;
  while (frame.history.size() > 1 &&
         (frame.history.begin()->first < newest - cache_ns_ || frame.history.size() > kMaxSamplesPerFrame))
    frame.history.erase(frame.history.begin());
  return std::nullopt;
}

std::optional<Eigen::Isometry3d> TfBuffer::link(const std::string& child, const Frame& frame,
                                                std::int64_t stamp_ns, TfLookup& failure) const {
  auto isometry = [](const Sample& s) {
    Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
    t.linear() = s.rotation.toRotationMatrix();
    t.translation() = s.translation;
    return t;
  };
  if (frame.is_static) return isometry(frame.fixed);
  const auto& h = frame.history;
  if (h.empty()) {
    failure = {TfLookup::Status::kNotYet, {}, "no transform " + frame.parent + " <- " + child + " yet"};
    return std::nullopt;
  }
  if (stamp_ns == 0) return isometry(h.rbegin()->second);
  auto after = h.lower_bound(stamp_ns);
  if (after == h.end()) {
    failure = {TfLookup::Status::kNotYet,
               {},
               "transform " + frame.parent + " <- " + child + " is known up to " +
                   std::to_string(h.rbegin()->first) + " ns, the lookup is at " + std::to_string(stamp_ns)};
    return std::nullopt;
  }
  if (after->first == stamp_ns) return isometry(after->second);
  if (after == h.begin()) {
    failure = {TfLookup::Status::kUnavailable,
               {},
               "time " + std::to_string(stamp_ns) + " ns is before the oldest transform " + frame.parent +
                   " <- " + child + " the buffer holds (" + std::to_string(h.begin()->first) + ")"};
    return std::nullopt;
  }
  auto before = std::prev(after);
  const double f =
      static_cast<double>(stamp_ns - before->first) / static_cast<double>(after->first - before->first);
  Sample s{before->second.translation + f * (after->second.translation - before->second.translation),
           before->second.rotation.slerp(f, after->second.rotation)};
  return isometry(s);
}

TfLookup TfBuffer::lookup(const std::string& target, const std::string& source, std::int64_t stamp_ns) const {
  if (target == source) return {TfLookup::Status::kOk, Eigen::Isometry3d::Identity(), {}};
  // Each frame's chain of ancestors, itself first.
  auto chain = [&](const std::string& start) {
    std::vector<std::string> frames{start};
    for (int depth = 0; depth < kMaxDepth; ++depth) {
      auto it = frames_.find(frames.back());
      if (it == frames_.end()) break;
      frames.push_back(it->second.parent);
    }
    return frames;
  };
  const std::vector<std::string> up_source = chain(source);
  const std::vector<std::string> up_target = chain(target);
  std::size_t common_in_source = up_source.size(), common_in_target = 0;
  for (std::size_t i = 0; i < up_source.size() && common_in_source == up_source.size(); ++i)
    for (std::size_t j = 0; j < up_target.size(); ++j)
      if (up_source[i] == up_target[j]) {
        common_in_source = i;
        common_in_target = j;
        break;
      }
  if (common_in_source == up_source.size()) {
    TfLookup r;
    r.status =
        hasFrame(source) && hasFrame(target) ? TfLookup::Status::kUnavailable : TfLookup::Status::kNotYet;
    r.reason = !hasFrame(source)   ? "frame '" + source + "' is not in the TF tree (yet)"
               : !hasFrame(target) ? "frame '" + target + "' is not in the TF tree (yet)"
                                   : "frames '" + source + "' and '" + target + "' are not connected";
    return r;
  }
  // ancestor <- source, and ancestor <- target, composed link by link.
  TfLookup failure;
  auto toAncestor = [&](const std::vector<std::string>& frames,
                        std::size_t common) -> std::optional<Eigen::Isometry3d> {
    Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
    for (std::size_t i = 0; i < common; ++i) {
      auto l = link(frames[i], frames_.at(frames[i]), stamp_ns, failure);
      if (!l) return std::nullopt;
      t = *l * t;
    }
    return t;
  };
  const auto from_source = toAncestor(up_source, common_in_source);
  if (!from_source) return failure;
  const auto from_target = toAncestor(up_target, common_in_target);
  if (!from_target) return failure;
  return {TfLookup::Status::kOk, from_target->inverse() * *from_source, {}};
}

}  // namespace densemap::ros2
