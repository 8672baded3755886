#include "densemap/map/map_file.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>
#include <stdexcept>
#include <streambuf>
#include <vector>

#include <fmt/format.h>

#include "densemap/map/grid_map.h"
#include "densemap/map/octree_map.h"

namespace densemap::map {

namespace {

/// An input stream over bytes already in memory (OctoMap's readers take streams; no copy of the file).
class ViewBuffer : public std::streambuf {
 public:
  explicit ViewBuffer(std::string_view bytes) {
    char* begin = const_cast<char*>(bytes.data());  // read only: streambuf's get area is non-const
    setg(begin, begin, begin + bytes.size());
  }
};

/// The OcTree to write: the octree backend's own, else a converted copy kept in `copy`.
const octomap::OcTree& treeOf(const OccupancyMap& map, std::unique_ptr<octomap::OcTree>& copy) {
  if (const auto* octree = dynamic_cast<const OctreeMap*>(&map)) return octree->tree();
  copy = toOcTree(map);
  return *copy;
}

}  // namespace

std::unique_ptr<octomap::OcTree> toOcTree(const OccupancyMap& map) {
  auto tree = OctreeMap::makeTree(map.resolution(), map.params());
  map.forEachCell([&](const VoxelKey& k, float v) {
    tree->setNodeValue(octomap::OcTreeKey(k[0], k[1], k[2]), v, /*lazy_eval=*/true);
  });
  tree->updateInnerOccupancy();
  tree->prune();
  return tree;
}

std::string encodeMap(const OccupancyMap& map, OctomapFormat format) {
  std::unique_ptr<octomap::OcTree> copy;
  const octomap::OcTree& tree = treeOf(map, copy);
  std::ostringstream out;
  // writeBinaryConst: the non-const writeBinary converts the tree to max-likelihood in place.
  const bool ok = format == OctomapFormat::kBinary ? tree.writeBinaryConst(out) : tree.write(out);
  if (!ok) throw std::runtime_error("OctoMap could not encode the map");
  return std::move(out).str();
}

std::string octomapMessageData(const OccupancyMap& map, OctomapFormat format) {
  std::unique_ptr<octomap::OcTree> copy;
  const octomap::OcTree& tree = treeOf(map, copy);
  std::ostringstream out;
  if (format == OctomapFormat::kBinary)
    tree.writeBinaryData(out);
  else
    tree.writeData(out);
  if (!out) throw std::runtime_error("OctoMap could not encode the map");
  return std::move(out).str();
}

void saveMap(const OccupancyMap& map, const std::string& path) {
  namespace fs = std::filesystem;
  const fs::path target(path);
  const std::string ext = target.extension().string();
  if (ext != ".bt" && ext != ".ot") {
    throw std::runtime_error("cannot save '" + path + "': the file name must end in .bt or .ot");
  }
  std::error_code ec;
  if (target.has_parent_path()) fs::create_directories(target.parent_path(), ec);
  const std::string tmp = path + ".tmp";
  std::unique_ptr<octomap::OcTree> copy;
  const octomap::OcTree& tree = treeOf(map, copy);
  const bool ok = ext == ".bt" ? tree.writeBinaryConst(tmp) : tree.write(tmp);
  if (!ok) {
    fs::remove(tmp, ec);
    throw std::runtime_error("cannot write '" + path + "' (is the directory writable?)");
  }
  fs::rename(tmp, target, ec);
  if (ec) throw std::runtime_error("cannot move the saved map into place at '" + path + "': " + ec.message());
}

std::unique_ptr<OccupancyMap> decodeMap(std::string_view bytes, const MapOptions& options,
                                        const MapLoadLimits& limits) {
  const bool grid = options.backend == "grid";
  std::vector<OctomapLeaf> leaves;
  std::uint64_t cells = 0;
  const OctomapHeader header = parseOctomapFile(
      bytes,
      [&](const OctomapLeaf& l) {
        if (!grid) return;  // the octree reads the checked bytes itself, node for node
        cells += std::uint64_t{1} << (3 * (16 - l.depth));
        if (cells > limits.max_cells)
          throw MapFileError(fmt::format("the map expands to more than {} cells (the grid backend's limit)",
                                         limits.max_cells));
        leaves.push_back(l);
      },
      limits.max_bytes);
  if (std::abs(header.resolution - options.resolution) > 1e-9 * options.resolution)
    throw MapFileError(fmt::format(
        "the file's resolution is {} m and this map's is {} m; start the server with --resolution {}",
        header.resolution, options.resolution, header.resolution));
  auto map = makeMap(options);
  if (auto* octree = dynamic_cast<OctreeMap*>(map.get())) {
    octomap::OcTree& tree = octree->mutableTree();
    tree.clear();
    if (header.nodes > 0) {
      ViewBuffer buffer(bytes.substr(header.data_offset));
      std::istream in(&buffer);
      if (header.format == OctomapFormat::kBinary) {
        tree.readBinaryData(in);
        tree.updateInnerOccupancy();  // OctoMap's .bt reader leaves inner nodes at the upper clamp
      } else {
        tree.readData(in);
      }
      if (!in) throw MapFileError("OctoMap could not read the tree data");
    }
    return map;
  }
  auto& g = dynamic_cast<GridMap&>(*map);
  const LogOdds& lo = g.logOddsParams();
  for (const OctomapLeaf& l : leaves) {
    const float v = header.format == OctomapFormat::kBinary ? (l.occupied ? lo.max : lo.min) : l.log_odds;
    const int side = 1 << (16 - l.depth);
    for (int x = 0; x < side; ++x)
      for (int y = 0; y < side; ++y)
        for (int z = 0; z < side; ++z)
          g.setLogOdds(VoxelKey{{static_cast<geometry::KeyCoord>(l.lo[0] + x),
                                 static_cast<geometry::KeyCoord>(l.lo[1] + y),
                                 static_cast<geometry::KeyCoord>(l.lo[2] + z)}},
                       v);
  }
  return map;
}

}  // namespace densemap::map
