// Sequence directory: clouds/<i>.pcd (sensor frame) + poses/<i>.txt (4x4 world <- sensor), i = 0..N-1.
#pragma once

#include "densemap/io/scan_source.h"

namespace densemap::io {

class SequenceDirectorySource : public ScanSource {
 public:
  explicit SequenceDirectorySource(std::string dir);
  std::size_t size() const override { return count_; }
  Scan read(std::size_t i) const override;
  std::string describe() const override;

 private:
  std::string dir_;
  std::size_t count_ = 0;
};

/// Reads a 4x4 row-major matrix (whitespace separated); throws SourceError naming the file.
Eigen::Isometry3d readPoseMatrix(const std::string& path);

}  // namespace densemap::io
