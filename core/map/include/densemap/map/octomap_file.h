// OctoMap's two map formats (.bt: each leaf free or occupied; .ot: each node's log-odds), read by our own
// bounds-checked parser: a file from anyone (truncated, hostile, with huge claimed sizes or a recursion
// deeper than the tree) gives a clear error, never a crash or a half-loaded map. OctoMap's own reader
// trusts its input (unbounded recursion on a crafted .ot), so it only ever sees bytes this parser accepted.
#pragma once

#include <cstdint>
#include <functional>
#include <stdexcept>
#include <string>
#include <string_view>

#include "densemap/geometry/voxel_key.h"

namespace densemap::map {

class MapFileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

enum class OctomapFormat { kBinary /* .bt */, kFull /* .ot */ };

struct OctomapHeader {
  OctomapFormat format = OctomapFormat::kBinary;
  std::string id;           ///< tree type; only "OcTree" is accepted
  std::uint64_t nodes = 0;  ///< the header's node count (checked against the data)
  double resolution = 0.0;
  std::size_t data_offset = 0;  ///< where the node data starts in the file
};

/// A leaf of the file's tree: the cells lo..lo + size - 1 on every axis (size = 2^(16 - depth), so a
/// pruned leaf stands for many cells). In .bt files `occupied` says the state and `log_odds` is unset;
/// in .ot files `log_odds` is the node's value.
struct OctomapLeaf {
  geometry::VoxelKey lo;
  unsigned depth = 16;
  bool occupied = false;
  float log_odds = 0.0f;
};

/// Parses the whole file (header and every node); calls `leaf` once per leaf in file order. Throws
/// MapFileError saying what is wrong and where. Files over `max_bytes` are refused before parsing.
OctomapHeader parseOctomapFile(std::string_view bytes, const std::function<void(const OctomapLeaf&)>& leaf,
                               std::size_t max_bytes = std::size_t{1} << 32);

}  // namespace densemap::map
