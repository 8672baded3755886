// The option tables every program shares: logging, the map (backend, resolution, sensor model) and the
// update method. One declaration each; densemap-server, -replay, -query, -map, -bench, -eval and -iln
// all take them from here.
#pragma once

#include <string>

#include "densemap/cli/option_table.h"
#include "densemap/dense/dense_layer_factory.h"
#include "densemap/io/scan_source.h"
#include "densemap/map/map_factory.h"
#include "densemap/update/update_engine.h"

namespace densemap::cli {

/// What to read: the source specification, the scan range and how gaps are treated.
struct SourceSelection {
  std::string source = "sim";
  std::string scans;  ///< "FIRST:LAST", "N", "FIRST:" or "" (all)
  io::SourceOptions options;
};

/// --source, --scans, --allow-gaps and the ROS 2 frame options.
OptionTable sourceOptions(SourceSelection& selection);
/// --cloud-topic, --frame-id, --base-frame-id, --pose-topic: how ROS 2 clouds are placed (bags and the edge).
void addFrameOptions(OptionTable& table, ros2::FrameOptions& frames);
/// --log-level.
OptionTable loggingOptions(std::string& level);
/// --backend, --resolution, --prob-hit, --prob-miss, --clamp-min, --clamp-max, --decay-s, --decay-step-s.
OptionTable mapOptions(map::MapOptions& options);
/// --method, --semantics, --max-range.
OptionTable updateOptions(update::UpdateOptions& options);
/// The kernel layers' settings (Ch. 3) shared by densemap-server and densemap-eval: --dense-free-sample-
/// distance, --dense-free-voxel, --dense-min-search-radius, --akimap-preset and the two AKIMap extensions
/// (--dense-isotropic-free, --dense-min-occupied-radius), which the preset sets unless given.
OptionTable kernelLayerOptions(dense::DenseLayerOptions& options);

}  // namespace densemap::cli
