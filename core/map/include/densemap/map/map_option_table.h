// The map's options (backend, resolution, sensor model, decay) as an option table.
#pragma once

#include "densemap/map/map_factory.h"
#include "densemap/options/option_table.h"

namespace densemap::map {

/// --backend, --resolution, --prob-hit, --prob-miss, --clamp-min, --clamp-max, --decay-s, --decay-step-s.
[[nodiscard]] options::OptionTable mapOptionTable(MapOptions& options);

}  // namespace densemap::map
