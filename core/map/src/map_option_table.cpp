#include "densemap/map/map_option_table.h"

namespace densemap::map {

options::OptionTable mapOptionTable(MapOptions& o) {
  options::OptionTable t("Map");
  t.add("backend", o.backend, "grid (hashed 16^3 blocks, fastest) or octree (OctoMap's OcTree)")
      .oneOf({"grid", "octree"});
  t.add("resolution", o.resolution, "voxel edge in metres").range(0.001, 100.0);
  t.add("prob-hit", o.params.prob_hit, "P(occupied) of a cell holding an endpoint").range(0.5, 1.0);
  t.add("prob-miss", o.params.prob_miss, "P(occupied) of a cell a ray crosses").range(0.0, 0.5);
  t.add("clamp-min", o.params.clamp_min, "lower clamping probability (Sec. 2.2.1)").range(0.0, 1.0);
  t.add("clamp-max", o.params.clamp_max, "upper clamping probability").range(0.0, 1.0).checkedBy([&o] {
    return o.params.validate();
  });
  t.add("decay-s", o.decay.seconds_to_unknown,
        "decay (grid only): seconds without observations for a cell at the upper clamp to become unknown; "
        "every known cell relaxes toward unknown at clamp-max's log-odds over this time (0: off, the "
        "OctoMap-equal map)")
      .range(0.0, 1e7);
  t.add("decay-step-s", o.decay.step_s,
        "decay is applied in steps of this much map time (the scans' receive times in the server)")
      .range(0.01, 3600.0)
      .checkedBy([&o] {
        if (o.decay.enabled() && o.backend != "grid") return std::string("--decay-s needs --backend grid");
        return o.decay.validate();
      });
  return t;
}

}  // namespace densemap::map
