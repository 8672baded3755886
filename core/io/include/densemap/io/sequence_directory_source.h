// Sequence directory: clouds/<i>.pcd (sensor frame) + poses/<i>.txt (4x4 world <- sensor), i = 0..N-1.
#pragma once

#include <string_view>
#include <vector>

#include "densemap/io/numbered_files.h"
#include "densemap/io/scan_source.h"

namespace densemap::io {

class SequenceDirectorySource : public ScanSource {
 public:
  /// Checks that clouds/ runs from 0 without a gap (unless options.allow_gaps) and that every cloud has its
  /// pose file.
  explicit SequenceDirectorySource(std::string dir, const SourceOptions& options = {});
  std::size_t size() const override { return clouds_.size(); }
  Scan read(std::size_t i) const override;
  std::string describe() const override;

 private:
  std::string dir_;
  std::vector<NumberedFile> clouds_;
};

/// Parses a 4x4 row-major rigid transform (whitespace separated, last row 0 0 0 1); throws SourceError
/// starting with `name` (a NaN is reported as NaN, a scaled rotation as not orthonormal).
Eigen::Isometry3d parsePoseMatrix(std::string_view text, const std::string& name);
/// Reads a pose file (see parsePoseMatrix).
Eigen::Isometry3d readPoseMatrix(const std::string& path);

}  // namespace densemap::io
