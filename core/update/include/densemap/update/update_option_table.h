// The update's options (method, semantics, range) as an option table.
#pragma once

#include "densemap/options/option_table.h"
#include "densemap/update/update_engine.h"

namespace densemap::update {

/// --method, --semantics, --max-range.
[[nodiscard]] options::OptionTable updateOptionTable(UpdateOptions& options);

}  // namespace densemap::update
