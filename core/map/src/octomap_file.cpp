#include "densemap/map/octomap_file.h"

#include <charconv>
#include <cmath>
#include <cstring>

#include <fmt/format.h>

namespace densemap::map {

namespace {

using geometry::kKeyDepth;
constexpr std::string_view kBinaryFirstLine = "# Octomap OcTree binary file";
constexpr std::string_view kFullFirstLine = "# Octomap OcTree file";
constexpr std::size_t kMaxHeaderBytes = 64 * 1024;

std::string_view trimmed(std::string_view s) {
  while (!s.empty() && (s.back() == '\r' || s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  return s;
}

OctomapHeader parseHeader(std::string_view bytes) {
  OctomapHeader h;
  std::size_t pos = 0;
  auto nextLine = [&]() -> std::string_view {
    const std::size_t end = bytes.find('\n', pos);
    if (end == std::string_view::npos || end > kMaxHeaderBytes)
      throw MapFileError("the header ends without a 'data' line (truncated, or not an OctoMap file)");
    const std::string_view line = bytes.substr(pos, end - pos);
    pos = end + 1;
    return trimmed(line);
  };
  const std::string_view first = nextLine();
  if (first == kBinaryFirstLine) {
    h.format = OctomapFormat::kBinary;
  } else if (first == kFullFirstLine) {
    h.format = OctomapFormat::kFull;
  } else {
    throw MapFileError(
        "not an OctoMap file: the first line must be '# Octomap OcTree binary file' (.bt) or "
        "'# Octomap OcTree file' (.ot)");
  }
  bool have_size = false, have_res = false;
  for (;;) {
    const std::string_view line = nextLine();
    if (line.empty() || line.front() == '#') continue;
    if (line == "data") break;
    const std::size_t space = line.find_first_of(" \t");
    const std::string_view key = line.substr(0, space);
    const std::string_view value = space == std::string_view::npos ? "" : trimmed(line.substr(space + 1));
    if (key == "id") {
      h.id = std::string(value);
    } else if (key == "size") {
      const auto r = std::from_chars(value.data(), value.data() + value.size(), h.nodes);
      if (r.ec != std::errc() || r.ptr != value.data() + value.size())
        throw MapFileError(fmt::format("bad node count '{}' in the header", value));
      have_size = true;
    } else if (key == "res") {
      // from_chars for double is in libstdc++ 11+.
      const auto r = std::from_chars(value.data(), value.data() + value.size(), h.resolution);
      if (r.ec != std::errc() || r.ptr != value.data() + value.size() || !std::isfinite(h.resolution) ||
          h.resolution <= 0.0 || h.resolution > 1000.0)
        throw MapFileError(fmt::format("bad resolution '{}' in the header (a number in (0, 1000] m)", value));
      have_res = true;
    } else {
      throw MapFileError(fmt::format("unknown header line '{}'", line.substr(0, 80)));
    }
  }
  if (h.id != "OcTree")
    throw MapFileError("the tree type is '" + h.id + "'; only OcTree maps (id OcTree) can be loaded");
  if (!have_size || !have_res) throw MapFileError("the header lacks its 'size' or 'res' line");
  h.data_offset = pos;
  return h;
}

/// Walks the node data depth first (at most kKeyDepth deep: the recursion is bounded by the format).
class NodeReader {
 public:
  NodeReader(std::string_view data, const std::function<void(const OctomapLeaf&)>& leaf)
      : data_(data), leaf_(leaf) {}

  std::size_t consumed() const { return pos_; }
  std::uint64_t nodes() const { return nodes_; }

  void binaryNode(const geometry::VoxelKey& lo, unsigned depth) {
    ++nodes_;
    const std::uint8_t b[2] = {byte(), byte()};
    bool inner[8] = {};
    bool any = false;
    for (unsigned i = 0; i < 8; ++i) {
      const unsigned bits = (b[i / 4] >> (2 * (i % 4))) & 3u;
      if (bits == 0) continue;
      any = true;
      if (bits == 3) {
        inner[i] = true;
        continue;
      }
      if (depth + 1 > kKeyDepth) throw error("a leaf below the finest level");
      ++nodes_;
      OctomapLeaf l;
      l.lo = child(lo, depth, i);
      l.depth = depth + 1;
      l.occupied = bits == 2;  // 01: free, 10: occupied (OctoMap's writeBinaryNode)
      leaf_(l);
    }
    if (!any) throw error("an inner node without children");
    for (unsigned i = 0; i < 8; ++i) {
      if (!inner[i]) continue;
      if (depth + 1 >= kKeyDepth) throw error("an inner node at the finest level");
      binaryNode(child(lo, depth, i), depth + 1);
    }
  }

  void fullNode(const geometry::VoxelKey& lo, unsigned depth) {
    ++nodes_;
    float value = 0.0f;
    need(sizeof value);
    std::memcpy(&value, data_.data() + pos_, sizeof value);
    pos_ += sizeof value;
    if (!std::isfinite(value)) throw error("a node whose log-odds is not finite");
    const std::uint8_t children = byte();
    if (children == 0) {
      if (depth == 0) throw error("a tree that is only its root");
      OctomapLeaf l;
      l.lo = lo;
      l.depth = depth;
      l.log_odds = value;
      leaf_(l);
      return;
    }
    if (depth >= kKeyDepth) throw error("children below the finest level");
    for (unsigned i = 0; i < 8; ++i) {
      if ((children >> i) & 1u) fullNode(child(lo, depth, i), depth + 1);
    }
  }

 private:
  static geometry::VoxelKey child(const geometry::VoxelKey& lo, unsigned depth, unsigned i) {
    // Child i of a node at `depth`: bit 0 of i is x, bit 1 y, bit 2 z (OctoMap's computeChildIdx).
    const unsigned half = 1u << (kKeyDepth - depth - 1);
    geometry::VoxelKey k = lo;
    for (int a = 0; a < 3; ++a) {
      if ((i >> a) & 1u) k[a] = static_cast<geometry::KeyCoord>(k[a] + half);
    }
    return k;
  }
  void need(std::size_t n) const {
    if (data_.size() - pos_ < n) throw error("the data ends in the middle of a node (truncated file)");
  }
  std::uint8_t byte() {
    need(1);
    return static_cast<std::uint8_t>(data_[pos_++]);
  }
  MapFileError error(const char* what) const {
    return MapFileError(fmt::format("corrupt tree data: {} (at data byte {})", what, pos_));
  }

  std::string_view data_;
  const std::function<void(const OctomapLeaf&)>& leaf_;
  std::size_t pos_ = 0;
  std::uint64_t nodes_ = 0;
};

}  // namespace

OctomapHeader parseOctomapFile(std::string_view bytes, const std::function<void(const OctomapLeaf&)>& leaf,
                               std::size_t max_bytes) {
  if (bytes.size() > max_bytes)
    throw MapFileError(fmt::format("the file has {} bytes; at most {} are read", bytes.size(), max_bytes));
  const OctomapHeader h = parseHeader(bytes);
  const std::string_view data = bytes.substr(h.data_offset);
  if (h.nodes == 0) {
    if (!data.empty()) throw MapFileError("the header says 0 nodes but node data follows");
    return h;
  }
  // Each node takes at least 2 bytes (.bt: 2 per inner node, leaves ride in their parent's; .ot: 5), so a
  // claimed size the file cannot hold is refused before any work.
  if (h.format == OctomapFormat::kFull && h.nodes > data.size() / 5)
    throw MapFileError(fmt::format("the header claims {} nodes; {} bytes of data hold at most {}", h.nodes,
                                   data.size(), data.size() / 5));
  NodeReader reader(data, leaf);
  const geometry::VoxelKey root{{0, 0, 0}};
  if (h.format == OctomapFormat::kBinary) {
    reader.binaryNode(root, 0);
  } else {
    reader.fullNode(root, 0);
  }
  if (reader.consumed() != data.size())
    throw MapFileError(fmt::format("{} bytes follow the end of the tree (corrupt or not one map)",
                                   data.size() - reader.consumed()));
  if (reader.nodes() != h.nodes)
    throw MapFileError(fmt::format("the header says {} nodes, the data holds {}", h.nodes, reader.nodes()));
  return h;
}

}  // namespace densemap::map
