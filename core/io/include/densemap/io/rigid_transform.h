// Poses from text: every source's pose, calibration and viewpoint passes through here, so each is checked
// the same way (finite, rotation orthonormal with determinant +1) and reported the same way.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Geometry>

namespace densemap::io {

/// Throws SourceError "<what>: ..." unless `translation` is finite and `rotation` is a rotation
/// (R R^T = I and det R = +1, within 1e-3; a scaled or all-zero matrix is not).
void checkRigid(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation, const std::string& what);
/// A rigid transform from `rows` x 4 numbers in row-major order (rows 3: KITTI's 3x4; rows 4: a 4x4 whose
/// last row must be 0 0 0 1). Words that are not numbers, the wrong count and NaN/Inf entries are
/// reported by position; the result passes checkRigid.
Eigen::Isometry3d parseRigidRows(const std::vector<std::string_view>& words, int rows,
                                 const std::string& what);

}  // namespace densemap::io
