// "Give me scan i": the one interface every reader and the simulator implement.
#pragma once

#include <cstddef>
#include <memory>
#include <string>

#include "densemap/io/scan.h"

namespace densemap::io {

class ScanSource {
 public:
  virtual ~ScanSource() = default;
  virtual std::size_t size() const = 0;
  /// Throws SourceError (naming the file) on missing, corrupt or truncated data.
  virtual Scan read(std::size_t i) const = 0;
  /// A short human-readable description ("kitti00 sequence directory, 60 scans").
  virtual std::string describe() const = 0;
};

/// How a source treats what is not there.
struct SourceOptions {
  /// Map the scans a numbered sequence holds when some are missing (by default a gap is an error).
  bool allow_gaps = false;
};

}  // namespace densemap::io
