#include "densemap/map/update_semantics.h"

namespace densemap::map {

std::string_view toString(UpdateSemantics s) { return s == UpdateSemantics::kBatch ? "batch" : "counting"; }

std::optional<UpdateSemantics> parseSemantics(std::string_view s) {
  if (s == "batch") return UpdateSemantics::kBatch;
  if (s == "counting") return UpdateSemantics::kCounting;
  return std::nullopt;
}

}  // namespace densemap::map
