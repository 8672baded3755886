// CRC-32 (zlib's) of any length: the journal's and the snapshots' checksums.
#pragma once

#include <zlib.h>

#include <algorithm>
#include <cstdint>
#include <string_view>

namespace densemap::server::durability {

inline std::uint32_t crc32Of(std::string_view bytes, std::uint32_t crc = 0) {
  uLong c = crc;
  while (!bytes.empty()) {  // zlib takes 32-bit lengths
    const std::size_t n = std::min<std::size_t>(bytes.size(), 1u << 30);
    c = ::crc32(c, reinterpret_cast<const Bytef*>(bytes.data()), static_cast<uInt>(n));
    bytes.remove_prefix(n);
  }
  return static_cast<std::uint32_t>(c);
}

}  // namespace densemap::server::durability
