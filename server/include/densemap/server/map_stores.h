// The two layers as the service shares them between their writer threads and the readers.
#pragma once

#include "densemap/dense/kernel_layer.h"
#include "densemap/map/occupancy_map.h"
#include "densemap/server/versioned_store.h"

namespace densemap::server {

/// The exact occupancy map (Ch. 2), written by the occupancy stage.
using MapStore = VersionedStore<map::OccupancyMap>;
/// The dense layer (Ch. 3), written by the dense stage.
using DenseStore = VersionedStore<dense::KernelLayer>;

}  // namespace densemap::server
