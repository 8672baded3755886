// World-frame PCD files whose VIEWPOINT is the sensor origin (la3dm): <name>_<k>.pcd, k = 1..N, or one file.
#pragma once

#include <vector>

#include "densemap/io/scan_source.h"

namespace densemap::io {

class ViewpointPcdSource : public ScanSource {
 public:
  /// `path` is a directory of numbered PCD files (no gaps unless options.allow_gaps) or a single PCD file.
  explicit ViewpointPcdSource(const std::string& path, const SourceOptions& options = {});
  std::size_t size() const override { return files_.size(); }
  Scan read(std::size_t i) const override;
  std::string describe() const override;

 private:
  std::string path_;
  std::vector<std::string> files_;  // sorted by their number
};

}  // namespace densemap::io
