#include "densemap/dense/dense_option_table.h"

namespace densemap::dense {

options::OptionTable kernelLayerOptionTable(DenseLayerOptions& o) {
  options::OptionTable t("Kernel layers (Ch. 3): AKIMap and BGK");
  t.add("dense-free-sample-distance", o.free_sample_distance, "one free sample per this many metres of ray")
      .range(0.001, 100.0);
  t.add("dense-free-voxel", o.free_voxel_size,
        "one free sample per voxel of this size (0: the dense resolution)")
      .range(0.0, 100.0);
  t.add("dense-min-search-radius", o.min_search_radius,
        "AKIMap: floor of every sample's neighbour search radius in metres (0: the dissertation's schedule)")
      .range(0.0, 100.0);
  t.add("akimap-preset", o.akimap_preset,
        "AKIMap's settings: measured (isotropic free kernels and a 0.3 m occupied radius floor, the best "
        "measured: above BGK on both la3dm scenes) or dissertation (Ch. 3 as it stands); the two "
        "options below override it when given")
      .oneOf({"measured", "dissertation"});
  options::OptionSpec& iso =
      t.add("dense-isotropic-free", o.isotropic_free_kernels,
            "AKIMap: isotropic kernels for free samples (default: from --akimap-preset)")
          .exampleOnly();  // a configuration file that sets it would override the preset
  options::OptionSpec& floor =
      t.add("dense-min-occupied-radius", o.min_occupied_search_radius,
            "AKIMap: floor of occupied samples' search radius in metres (default: from "
            "--akimap-preset; 0: the dissertation's)")
          .range(0.0, 100.0)
          .exampleOnly();
  // The preset sets what the user did not; given values win (the deque keeps these references valid).
  t.afterParse([&o, &iso, &floor] {
    const bool iso_value = o.isotropic_free_kernels;
    const double floor_value = o.min_occupied_search_radius;
    o.applyAkimapPreset(o.akimap_preset);
    if (iso.given) o.isotropic_free_kernels = iso_value;
    if (floor.given) o.min_occupied_search_radius = floor_value;
  });
  return t;
}

}  // namespace densemap::dense
