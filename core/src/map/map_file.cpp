#include "densemap/map/map_file.h"

#include <cstdio>
#include <filesystem>
#include <stdexcept>

#include "densemap/map/octree_map.h"

namespace densemap::map {

std::unique_ptr<octomap::OcTree> toOcTree(const OccupancyMap& map) {
  auto tree = OctreeMap::makeTree(map.resolution(), map.params());
  map.forEachCell([&](const VoxelKey& k, float v) {
    tree->setNodeValue(octomap::OcTreeKey(k[0], k[1], k[2]), v, /*lazy_eval=*/true);
  });
  tree->updateInnerOccupancy();
  tree->prune();
  return tree;
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
  const octomap::OcTree* tree = nullptr;
  if (const auto* octree = dynamic_cast<const OctreeMap*>(&map)) {
    tree = &octree->tree();
  } else {
    copy = toOcTree(map);
    tree = copy.get();
  }
  // writeBinaryConst: the non-const writeBinary converts the tree to max-likelihood in place.
  const bool ok = ext == ".bt" ? tree->writeBinaryConst(tmp) : tree->write(tmp);
  if (!ok) {
    fs::remove(tmp, ec);
    throw std::runtime_error("cannot write '" + path + "' (is the directory writable?)");
  }
  fs::rename(tmp, target, ec);
  if (ec) throw std::runtime_error("cannot move the saved map into place at '" + path + "': " + ec.message());
}

}  // namespace densemap::map
