// The kernel layers' options (Ch. 3) as an option table.
#pragma once

#include "densemap/dense/dense_layer_factory.h"
#include "densemap/options/option_table.h"

namespace densemap::dense {

/// The kernel layers' settings (Ch. 3) shared by densemap-server and densemap-eval: --dense-free-sample-
/// distance, --dense-free-voxel, --dense-min-search-radius, --akimap-preset and the two AKIMap extensions
/// (--dense-isotropic-free, --dense-min-occupied-radius), which the preset sets unless given.
[[nodiscard]] options::OptionTable kernelLayerOptionTable(DenseLayerOptions& options);

}  // namespace densemap::dense
