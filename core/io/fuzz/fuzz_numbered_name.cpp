// libFuzzer target for scan numbers in file names (la3dm's <name>_<k>.pcd, KITTI's NNNNNN.bin;
// core/io/src/numbered_files.cpp): a name parses to its stem and number or is refused with SourceError.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

#include "densemap/io/numbered_files.h"
#include "densemap/io/scan.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view name(reinterpret_cast<const char*>(data), size);
  try {
    const auto n = densemap::io::parseNumberedName(name, ".pcd");
    if (n) {
      // The number is what the digits before ".pcd" say: printing it back ends the name.
      const std::string digits = std::to_string(n->number);
      const std::string_view base = name.substr(0, name.size() - 4);
      if (base.substr(0, n->stem.size()) != n->stem) std::abort();
      if (base.size() < digits.size() || base.substr(base.size() - digits.size()) != digits) std::abort();
    }
  } catch (const densemap::io::SourceError&) {
  }
  return 0;
}
