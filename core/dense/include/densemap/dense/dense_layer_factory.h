// The one place that turns a dense-layer name (Ch. 3: AKIMap, or the BGK baseline) into a layer.
#pragma once

#include <memory>
#include <stdexcept>
#include <string>

#include "densemap/dense/kernel_layer.h"

namespace densemap::dense {

struct DenseLayerOptions {
  std::string method = "none";  ///< "none", "akimap" or "bgk"
  double resolution = 0.0;      ///< cell size; 0: the caller's default (the map's resolution)
  double free_sample_distance = 0.5;
  /// One free sample per voxel of this size (0: the resolution). 0.3 keeps a 64-beam LiDAR at ~226 ms per
  /// scan at 0.2 m (docs/BENCHMARKS.md).
  double free_voxel_size = 0.3;
  double max_range = 30.0;  ///< rays are cut here for the dense layer (metres; < 0: unlimited)
  std::uint64_t seed = 1;   ///< free-sample generator
  /// AKIMap: lower bound of every sample's search radius (0: the dissertation's schedule).
  double min_search_radius = 0.0;
  /// AKIMap's settings by name: "measured" (the default: the two extensions below, the best measured
  /// configuration, above BGK on both la3dm scenes, docs/BENCHMARKS.md) or "dissertation" (Ch. 3 as it
  /// stands: both off). cli::kernelLayerOptions applies it to the two fields a user did not set.
  std::string akimap_preset = "measured";
  /// AKIMap extensions (dense/adaptive_kernel_layer.h): isotropic free kernels, occupied radius floor.
  bool isotropic_free_kernels = true;
  double min_occupied_search_radius = 0.3;

  /// Sets the two extensions to `preset`'s values; throws std::invalid_argument for an unknown name.
  /// (Inline: the option tables use it without linking the kernel layers.)
  void applyAkimapPreset(const std::string& preset) {
    if (preset == "measured") {
      isotropic_free_kernels = true;
      min_occupied_search_radius = 0.3;
    } else if (preset == "dissertation") {
      isotropic_free_kernels = false;
      min_occupied_search_radius = 0.0;
    } else {
      throw std::invalid_argument("unknown AKIMap preset '" + preset + "' (use measured or dissertation)");
    }
    akimap_preset = preset;
  }
};

/// Null for "none"; throws std::invalid_argument for an unknown method. `default_resolution` is used
/// when options.resolution is 0.
std::unique_ptr<KernelLayer> makeDenseLayer(const DenseLayerOptions& options, double default_resolution);

}  // namespace densemap::dense
