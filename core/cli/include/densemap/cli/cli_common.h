// Helpers shared by the command-line tools: scan ranges, loading scans with progress, logging.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "densemap/geometry/voxel_key.h"
#include "densemap/io/scan_source.h"

namespace densemap::cli {

struct ScanRange {
  std::size_t first = 0;
  std::size_t last = 0;  ///< inclusive
};

/// Parses "FIRST:LAST" (inclusive), "N" (one scan), "FIRST:" (to the end) or "" (all); a range past the
/// source's end is an error.
/// Throws std::invalid_argument with a message saying what is wrong.
ScanRange parseScanRange(const std::string& text, std::size_t source_size);

/// A scan ready for insertion: world-frame points and the sensor origin.
struct WorldScan {
  std::vector<geometry::Vec3f> points;
  geometry::Vec3f origin;
};

/// Reads the range from the source, logging progress; throws io::SourceError.
std::vector<WorldScan> loadScans(const io::ScanSource& source, const ScanRange& range);

/// Sets spdlog's level ("info", "debug", ...) and pattern for tools, and sends the log to stderr.
void setupLogging(const std::string& level);

/// Sets the number of worker threads (0 = all cores); returns the count in use.
int setThreads(int threads);

/// A one-line progress indicator on stderr ("label 12/60"), only when stderr is a terminal.
class Progress {
 public:
  Progress(std::string label, std::size_t total);
  void step(std::size_t done);
  ~Progress();

 private:
  std::string label_;
  std::size_t total_;
  bool tty_;
};

}  // namespace densemap::cli
