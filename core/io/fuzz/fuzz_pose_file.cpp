// libFuzzer target for the text pose parsers: a sequence directory's 4x4 pose file, KITTI's calib.txt and
// poses.txt (core/io/src/sequence_directory_source.cpp, kitti_odometry_source.cpp, rigid_transform.cpp).
// The first byte picks the parser. Whatever parses is a rigid transform.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "densemap/io/kitti_odometry_source.h"
#include "densemap/io/sequence_directory_source.h"

namespace {
void checkRigid(const Eigen::Isometry3d& t) {
  const Eigen::Matrix3d r = t.linear();
  if (!t.matrix().allFinite() || (r * r.transpose() - Eigen::Matrix3d::Identity()).norm() > 1e-3 ||
      r.determinant() < 0)
    std::abort();
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::string_view text(reinterpret_cast<const char*>(data) + 1, size - 1);
  try {
    switch (data[0] % 3) {
      case 0:
        checkRigid(densemap::io::parsePoseMatrix(text, "pose.txt"));
        break;
      case 1:
        checkRigid(densemap::io::parseKittiCalibration(text, "calib.txt"));
        break;
      default:
        for (const auto& p : densemap::io::parseKittiPoses(text, "poses.txt")) checkRigid(p);
    }
  } catch (const densemap::io::SourceError&) {
  }
  return 0;
}
