// OctoMap's binary scan graph (.graph): per node a point cloud in the sensor frame and a 6D pose.
#pragma once

#include <vector>

#include "densemap/io/scan_source.h"

namespace densemap::io {

class ScanGraphSource : public ScanSource {
 public:
  /// Parses the whole file up front, validating every count against the file size.
  explicit ScanGraphSource(const std::string& path);
  std::size_t size() const override { return scans_.size(); }
  Scan read(std::size_t i) const override { return scans_.at(i); }
  std::string describe() const override;

 private:
  std::string path_;
  std::vector<Scan> scans_;
};

}  // namespace densemap::io
