// Saved maps load back: .ot (full log-odds) identically, cell for cell (octree: node for node); .bt with
// each cell's state at the clamping values, as OctoMap keeps it. Corrupt or hostile files give an error,
// never a crash or a partial map. On the simulator, and on kitti00 when ../shared/data is present.
#include <cmath>
#include <map>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "densemap/map/grid_map.h"
#include "densemap/map/map_file.h"
#include "densemap/map/octree_map.h"
#include "densemap/sources/open_source.h"
#include "densemap/update/update_engine.h"
#include "test_data.h"
#include "test_simulator.h"

namespace densemap::test {
namespace {

using map::MapFileError;
using map::OctomapFormat;

std::unique_ptr<map::OccupancyMap> buildMap(const std::string& backend, double resolution,
                                            const io::ScanSource& src, std::size_t scans) {
  auto m = map::makeMap({backend, resolution, {}});
  update::UpdateEngine engine;
  for (std::size_t i = 0; i < scans && i < src.size(); ++i) {
    const io::Scan s = src.read(i);
    engine.insert(*m, s.worldPoints(), s.origin());
  }
  return m;
}

std::map<std::uint64_t, float> cellsOf(const map::OccupancyMap& m) {
  std::map<std::uint64_t, float> cells;
  m.forEachCell([&](const geometry::VoxelKey& k, float v) { cells[k.packed()] = v; });
  return cells;
}

/// Saves as .ot and .bt, loads both back into either backend, and checks what each format keeps.
void expectRoundTrips(const map::OccupancyMap& original) {
  const auto cells = cellsOf(original);
  ASSERT_GT(cells.size(), 1000u);
  const map::LogOdds lo(original.params());
  const std::string ot = map::encodeMap(original, OctomapFormat::kFull);
  const std::string bt = map::encodeMap(original, OctomapFormat::kBinary);
  for (const std::string backend : {"grid", "octree"}) {
    const map::MapOptions options{backend, original.resolution(), original.params()};
    const auto full = map::decodeMap(ot, options);
    EXPECT_EQ(full->backendName(), backend);
    EXPECT_EQ(cellsOf(*full), cells) << ".ot into " << backend << ": every cell, same log-odds bits";
    const auto binary = map::decodeMap(bt, options);
    std::size_t wrong = 0;
    const auto loaded = cellsOf(*binary);
    EXPECT_EQ(loaded.size(), cells.size()) << ".bt into " << backend;
    for (const auto& [key, v] : cells) {
      const auto it = loaded.find(key);
      const float want = v >= lo.occupied ? lo.max : lo.min;
      if (it == loaded.end() || it->second != want) ++wrong;
    }
    EXPECT_EQ(wrong, 0u) << ".bt into " << backend << ": each cell's state at the clamping value";
  }
  if (const auto* octree = dynamic_cast<const map::OctreeMap*>(&original)) {
    const auto full = map::decodeMap(ot, {"octree", original.resolution(), original.params()});
    std::string why;
    EXPECT_TRUE(map::identicalTrees(dynamic_cast<map::OctreeMap&>(*full).tree(), octree->tree(), &why))
        << why;
  }
}

TEST(MapFile, SimulatorMapsRoundTripInBothFormats) {
  io::LidarSimulator sim(smallSimulator(4));
  expectRoundTrips(*buildMap("grid", 0.2, sim, 4));
  expectRoundTrips(*buildMap("octree", 0.25, sim, 4));
}

TEST(MapFile, Kitti00MapsRoundTripInBothFormats) {
  DENSEMAP_REQUIRE_DATA("kitti00");
  const auto src = sources::openSource(dataDir() + "/kitti00");
  expectRoundTrips(*buildMap("grid", 0.2, *src, 10));
  expectRoundTrips(*buildMap("octree", 0.2, *src, 10));
}

TEST(MapFile, AnEmptyMapRoundTrips) {
  const map::GridMap empty(0.2);
  for (const auto format : {OctomapFormat::kFull, OctomapFormat::kBinary}) {
    const auto m = map::decodeMap(map::encodeMap(empty, format), {"grid", 0.2, {}});
    EXPECT_EQ(m->knownCells(), 0u);
  }
}

TEST(MapFile, AnotherResolutionIsRefusedWithTheFix) {
  io::LidarSimulator sim(smallSimulator(1));
  const auto m = buildMap("grid", 0.2, sim, 1);
  try {
    map::decodeMap(map::encodeMap(*m, OctomapFormat::kFull), {"grid", 0.1, {}});
    FAIL() << "loaded a 0.2 m map into a 0.1 m one";
  } catch (const MapFileError& e) {
    EXPECT_NE(std::string(e.what()).find("--resolution 0.2"), std::string::npos) << e.what();
  }
}

TEST(MapFile, TruncatedAndCorruptedFilesGiveAnErrorNeverACrash) {
  io::LidarSimulator sim(smallSimulator(1, 16, 256));
  const auto m = buildMap("grid", 0.2, sim, 1);
  for (const auto format : {OctomapFormat::kFull, OctomapFormat::kBinary}) {
    const std::string bytes = map::encodeMap(*m, format);
    // Every prefix of the header, then prefixes through the data.
    std::size_t refused = 0, tried = 0;
    for (std::size_t n = 0; n < bytes.size(); n += n < 200 ? 1 : 997) {
      ++tried;
      try {
        map::decodeMap(bytes.substr(0, n), {"grid", 0.2, {}});
      } catch (const MapFileError&) {
        ++refused;
      }
    }
    EXPECT_EQ(refused, tried) << "every truncated file is refused";
    // Random byte flips: refused or loaded, never a crash (run under the fuzz target for more).
    std::mt19937 rng(7);
    for (int i = 0; i < 300; ++i) {
      std::string bad = bytes;
      for (int f = 0; f < 4; ++f) bad[rng() % bad.size()] = static_cast<char>(rng());
      try {
        map::decodeMap(bad, {"grid", 0.2, {}});
      } catch (const MapFileError&) {
      }
    }
  }
}

TEST(MapFile, HostileHeadersAndTreesAreRefused) {
  const std::string header = "# Octomap OcTree file\nid OcTree\nsize 30\nres 0.2\ndata\n";
  // A chain of first children deeper than the tree (OctoMap's own reader would recurse without end).
  std::string deep = header;
  for (int d = 0; d < 30; ++d) deep += std::string("\0\0\0\0\x01", 5);
  EXPECT_THROW(map::decodeMap(deep, {"grid", 0.2, {}}), MapFileError);
  EXPECT_THROW(map::decodeMap("# Octomap OcTree file\nid OcTree\nsize 999999999999\nres 0.2\ndata\n12345",
                              {"grid", 0.2, {}}),
               MapFileError)
      << "a node count the file cannot hold";
  EXPECT_THROW(
      map::decodeMap("# Octomap OcTree file\nid ColorOcTree\nsize 0\nres 0.2\ndata\n", {"grid", 0.2, {}}),
      MapFileError)
      << "another tree type";
  EXPECT_THROW(map::decodeMap("# Octomap OcTree file\nid OcTree\nsize 0\nres nan\ndata\n", {"grid", 0.2, {}}),
               MapFileError);
  EXPECT_THROW(map::decodeMap("not a map at all", {"grid", 0.2, {}}), MapFileError);
  EXPECT_THROW(map::decodeMap("", {"grid", 0.2, {}}), MapFileError);
  // A pruned leaf near the root expands to more cells than the grid's limit.
  std::string coarse = "# Octomap OcTree file\nid OcTree\nsize 2\nres 0.2\ndata\n";
  const float v = 1.0f;
  coarse += std::string(reinterpret_cast<const char*>(&v), 4) + std::string("\x01", 1);
  coarse += std::string(reinterpret_cast<const char*>(&v), 4) + std::string("\0", 1);
  EXPECT_THROW(map::decodeMap(coarse, {"grid", 0.2, {}}), MapFileError);
  // ...which the octree holds as the one leaf it is.
  EXPECT_EQ(map::decodeMap(coarse, {"octree", 0.2, {}})->backendName(), "octree");
}

}  // namespace
}  // namespace densemap::test
