// libFuzzer target for TF input (core/ros2/src/tf_buffer.cpp, sensor_pose.cpp): a TFMessage, Odometry or
// PoseStamped (first byte chooses) decodes and is added, or is refused; a lookup afterwards gives a
// rigid transform or a reason, never NaN.
#include <cstddef>
#include <cstdint>
#include <cstdlib>

#include "densemap/ros2/message_codec.h"
#include "densemap/ros2/sensor_pose.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  using namespace densemap::ros2;
  TfBuffer tf;
  const std::span<const std::uint8_t> sample(data + 1, size - 1);
  try {
    switch (data[0] % 4) {
      case 0:
        addTfMessage(tf, sample, false);
        break;
      case 1:
        addTfMessage(tf, sample, true);
        break;
      case 2:
        addPoseMessage(tf, kOdometryType, sample, "base");
        break;
      default:
        addPoseMessage(tf, kPoseStampedType, sample, "base");
        break;
    }
  } catch (const DecodeError&) {
    return 0;
  }
  for (const char* target : {"map", "odom"}) {
    const TfLookup r = tf.lookup(target, "base", 0);
    if (r.status == TfLookup::Status::kOk) {
      if (!r.transform.matrix().allFinite()) std::abort();
      const double det = r.transform.linear().determinant();
      if (det < 0.999 || det > 1.001) std::abort();
    } else if (r.reason.empty()) {
      std::abort();
    }
  }
  return 0;
}
