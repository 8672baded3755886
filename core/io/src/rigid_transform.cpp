#include "densemap/io/rigid_transform.h"

#include <cmath>

#include <fmt/format.h>

#include "densemap/io/scan.h"
#include "densemap/io/text_parse.h"

namespace densemap::io {

void checkRigid(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation,
                const std::string& what) {
  if (!translation.allFinite())
    throw SourceError(fmt::format("{}: translation ({} {} {}) is not finite", what, translation.x(),
                                  translation.y(), translation.z()));
  if (!rotation.allFinite()) throw SourceError(what + ": rotation has NaN or Inf entries");
  const double error = (rotation * rotation.transpose() - Eigen::Matrix3d::Identity()).norm();
  if (error > 1e-3)
    throw SourceError(
        fmt::format("{}: rotation is not orthonormal (|R R^T - I| = {:.3g}; scaled, sheared or "
                    "zero matrices are not poses)",
                    what, error));
  if (rotation.determinant() < 0) throw SourceError(what + ": rotation is a reflection (determinant -1)");
}

Eigen::Isometry3d parseRigidRows(const std::vector<std::string_view>& words, int rows,
                                 const std::string& what) {
  const std::size_t expected = static_cast<std::size_t>(rows) * 4;
  if (words.size() != expected)
    throw SourceError(fmt::format("{}: holds {} values; expected {} (a {}x4 row-major matrix)", what,
                                  words.size(), expected, rows));
  Eigen::Matrix<double, 4, 4, Eigen::RowMajor> m = Eigen::Matrix4d::Identity();
  for (std::size_t k = 0; k < expected; ++k) {
    const auto r = static_cast<int>(k / 4), c = static_cast<int>(k % 4);
    const auto v = parseDouble(words[k]);
    if (!v) throw SourceError(fmt::format("{}: entry ({},{}) '{}' is not a number", what, r, c, words[k]));
    if (!std::isfinite(*v)) throw SourceError(fmt::format("{}: entry ({},{}) is {}", what, r, c, words[k]));
    m(r, c) = *v;
  }
  if (rows == 4 && (m(3, 0) != 0 || m(3, 1) != 0 || m(3, 2) != 0 || m(3, 3) != 1))
    throw SourceError(fmt::format("{}: last row is {} {} {} {}; a rigid transform's is 0 0 0 1", what,
                                  m(3, 0), m(3, 1), m(3, 2), m(3, 3)));
  const Eigen::Matrix3d rot = m.topLeftCorner<3, 3>();
  const Eigen::Vector3d t = m.topRightCorner<3, 1>();
  checkRigid(rot, t, what);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = rot;
  pose.translation() = t;
  return pose;
}

}  // namespace densemap::io
