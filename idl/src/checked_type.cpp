#include "densemap/msg/checked_type.h"

#include <spdlog/spdlog.h>

namespace densemap::msg {

namespace {
std::atomic<std::uint64_t> undecodable{0};
}  // namespace

std::uint64_t undecodableSamples() { return undecodable.load(std::memory_order_relaxed); }

void countUndecodableSample() {
  const auto n = undecodable.fetch_add(1, std::memory_order_relaxed) + 1;
  // A hostile or broken peer can send these at line rate: say so once, then every 1000th.
  if (n == 1 || n % 1000 == 0)
    spdlog::warn(
        "refused {} DDS sample(s) that did not decode (malformed CDR from a participant on this domain)", n);
}

}  // namespace densemap::msg
