// Datasets number their scans in file names (clouds/7.pcd, velodyne/000007.bin, sim_structured_7.pcd). A
// missing number is an error, never a silent stop or a shift of every later scan onto the wrong pose.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace densemap::io {

struct NumberedName {
  std::string stem;  ///< what precedes the number ("sim_structured_" or "")
  std::uint64_t number = 0;
};

/// Splits "<stem><digits><suffix>" (e.g. "scan_12.pcd" with suffix ".pcd"); nullopt when the name does not
/// have that shape. Throws SourceError when the digits do not fit in 18 decimal places.
std::optional<NumberedName> parseNumberedName(std::string_view file_name, std::string_view suffix);

struct NumberedFile {
  std::uint64_t number = 0;
  std::string path;
};

/// The files of `dir` named "<stem><number><suffix>", sorted by number. All must share one stem; numbers
/// must run without a gap from the first unless `allow_gaps` (the error names the first missing file and
/// the flag). Throws SourceError when none is found.
std::vector<NumberedFile> listNumberedFiles(const std::string& dir, std::string_view suffix, bool allow_gaps);

}  // namespace densemap::io
