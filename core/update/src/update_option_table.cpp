#include "densemap/update/update_option_table.h"

namespace densemap::update {

options::OptionTable updateOptionTable(UpdateOptions& o) {
  options::OptionTable t("Update (Ch. 2)");
  t.addChoice(
      "method", o.method,
      {{"fastest", UpdateMethod::kFastest},
       {"baseline", UpdateMethod::kBaseline},
       {"superrays", UpdateMethod::kSuperRays},
       {"culling", UpdateMethod::kCullingRegion},
       {"superrays+culling", UpdateMethod::kSuperRaysCulling}},
      "update method; all give the same map (super rays Sec. 2.3.1-2.3.4, culling region Sec. 2.3.5). "
      "fastest: the baseline, unless the scans are dense enough for super rays to save walking (then per "
      "scan whichever of the four is measured fastest so far)");
  t.addChoice("semantics", o.semantics,
              {{"batch", map::UpdateSemantics::kBatch}, {"counting", map::UpdateSemantics::kCounting}},
              "batch (OctoMap's insertPointCloud) or counting (Sec. 2.3.4)");
  t.add("max-range", o.max_range, "cut rays at this range in metres (< 0: unlimited)").range(-1.0, 1e5);
  return t;
}

}  // namespace densemap::update
