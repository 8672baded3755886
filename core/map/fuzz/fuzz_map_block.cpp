// libFuzzer target for a map block's bytes as the rolling window reads them back (PaletteBlock::decode):
// damage must be refused with util::FormatError, and what decodes must encode back to the same bytes.
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "densemap/map/palette_block.h"
#include "densemap/util/byte_codec.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  try {
    const densemap::map::PaletteBlock b = densemap::map::PaletteBlock::decode(bytes);
    if (b.encode() != bytes) std::abort();
    (void)b.knownCount();
  } catch (const densemap::util::FormatError&) {
  }
  return 0;
}
