// densemap-octomap-reference: OctoMap's own OcTree::insertPointCloud on the scans densemap-bench hands it
// (an OctoMap .graph), in a process of its own. densemap-bench's reference: no densemap thread,
// allocator setting or cache state of the benchmark can slow or speed it. The only densemap code here is
// the file parser, which runs before the first timed insert and starts no threads.
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include <octomap/octomap.h>
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "densemap/io/scan_graph_source.h"
#include "densemap/io/text_parse.h"

int main(int argc, char** argv) {
  CLI::App app{
      "densemap-octomap-reference: OctoMap insertPointCloud on each scan of an OctoMap .graph (one "
      "world-frame "
      "cloud per node, the node's position the sensor origin), timed per scan; prints one JSON object"};
  std::string graph_path, tree_path;
  double resolution = 0.2, max_range = -1.0;
  app.add_option("--graph", graph_path,
                 "scans as an OctoMap .graph with world-frame clouds, each node's position the sensor origin "
                 "(densemap-bench --graph-out writes one)")
      ->required();
  app.add_option("--resolution", resolution, "voxel size in metres")
      ->capture_default_str()
      ->check(CLI::Range(1e-4, 1e3));
  app.add_option("--max-range", max_range, "cut rays at this range (<0: unlimited)")->capture_default_str();
  app.add_option("--write-tree", tree_path, "also write the map as an OctoMap .ot (full probabilities)");
  CLI11_PARSE(app, argc, argv);

  // The file is read with densemap's own .graph parser (fuzzed: OctoMap's reader aborts on a truncated
  // file), on this thread and before the first timed insert; nothing else of densemap runs here.
  std::vector<densemap::io::Scan> scans;
  try {
    scans = densemap::io::parseScanGraph(
        densemap::io::readFileBytes(graph_path, std::size_t{1} << 34, "scan graph"), graph_path);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "densemap-octomap-reference: %s\n", e.what());
    return 1;
  }
  std::vector<std::pair<octomap::Pointcloud, octomap::point3d>> clouds;
  for (const auto& s : scans) {
    if (!s.pose.linear().isIdentity(0.0)) {
      std::fprintf(stderr,
                   "densemap-octomap-reference: %s: scan %zu has a rotation; this program takes world-frame "
                   "clouds as densemap-bench writes them (--graph-out)\n",
                   graph_path.c_str(), s.index);
      return 1;
    }
    octomap::Pointcloud cloud;
    cloud.reserve(s.points.size());
    for (const auto& p : s.points) cloud.push_back(p.x(), p.y(), p.z());
    const Eigen::Vector3d o = s.pose.translation();
    clouds.emplace_back(
        std::move(cloud),
        octomap::point3d(static_cast<float>(o.x()), static_cast<float>(o.y()), static_cast<float>(o.z())));
  }
  scans.clear();
  scans.shrink_to_fit();
  octomap::OcTree tree(resolution);
  std::vector<double> scan_ms;
  double total_ms = 0.0;
  std::size_t points = 0;
  for (const auto& [cloud, origin] : clouds) {
    const auto t = std::chrono::steady_clock::now();
    tree.insertPointCloud(cloud, origin, max_range, false, false);
    scan_ms.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t).count());
    total_ms += scan_ms.back();
    points += cloud.size();
  }
  if (!tree_path.empty() && !tree.write(tree_path)) {
    std::fprintf(stderr, "densemap-octomap-reference: cannot write %s\n", tree_path.c_str());
    return 1;
  }
  const nlohmann::json out = {{"scans", scan_ms.size()},
                              {"points", points},
                              {"total_ms", total_ms},
                              {"scan_ms", scan_ms},
                              {"memory_bytes", tree.memoryUsage()},
                              {"nodes", tree.size()}};
  std::printf("%s\n", out.dump().c_str());
  return 0;
}
