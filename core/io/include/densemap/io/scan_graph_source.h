// OctoMap's binary scan graph (.graph): per node a point cloud in the sensor frame and a 6D pose.
#pragma once

#include <string_view>
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

/// The scans of a .graph held in memory; SourceError (starting with `name`, giving the byte) on a count
/// larger than the bytes that remain, a non-finite point or an invalid pose.
std::vector<Scan> parseScanGraph(std::string_view bytes, const std::string& name);

}  // namespace densemap::io
