// What to read (a source, a scan range, gaps, ROS 2 frames) as an option table.
#pragma once

#include <string>

#include "densemap/options/option_table.h"
#include "densemap/sources/open_source.h"

namespace densemap::sources {

/// What to read: the source specification, the scan range and how gaps are treated.
struct SourceSelection {
  std::string source = "sim";
  std::string scans;  ///< "FIRST:LAST", "N", "FIRST:" or "" (all)
  OpenOptions options;
};

/// --source, --scans, --allow-gaps and the ROS 2 frame options.
[[nodiscard]] options::OptionTable sourceOptionTable(SourceSelection& selection);

}  // namespace densemap::sources
