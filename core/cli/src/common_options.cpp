#include "densemap/cli/common_options.h"

namespace densemap::cli {

options::OptionTable loggingOptions(std::string& level) {
  options::OptionTable t("Logging");
  t.add("log-level", level, "how much to log")
      .oneOf({"trace", "debug", "info", "warn", "error", "critical", "off"});
  return t;
}

}  // namespace densemap::cli
