// The ROS 2 views of a map: the 2D projection of a height band and the occupied centres.
#include <gtest/gtest.h>

#include "densemap/map/grid_map.h"
#include "densemap/map/map_projection.h"
#include "densemap/update/update_engine.h"

namespace densemap::map {
namespace {

TEST(MapProjection, ABandProjectsOccupiedOverFreeOverUnknown) {
  GridMap m(1.0);
  const auto& conv = m.converter();
  auto set = [&](float x, float y, float z, float v) {
    geometry::VoxelKey k;
    ASSERT_TRUE(conv.toKey(geometry::Vec3f(x, y, z), k));
    m.setLogOdds(k, v);
  };
  set(0.5f, 0.5f, 0.5f, -2.0f);  // free
  set(0.5f, 0.5f, 1.5f, 2.0f);   // occupied above it: the column is occupied
  set(2.5f, 0.5f, 0.5f, -2.0f);  // free column
  set(2.5f, 2.5f, 5.5f, 2.0f);   // occupied, but above the band
  set(1.5f, 1.5f, 0.5f, -2.0f);  // free, in the band
  const ProjectedGrid g = projectToGrid(m, 0.0, 2.0);
  EXPECT_EQ(g.width, 3u);
  EXPECT_EQ(g.height, 2u);
  EXPECT_DOUBLE_EQ(g.origin_x, 0.0);
  EXPECT_DOUBLE_EQ(g.origin_y, 0.0);
  const std::vector<std::int8_t> want = {100, -1, 0, -1, 0, -1};
  EXPECT_EQ(g.cells, want);
  EXPECT_EQ(occupiedCentres(m).size(), 2u);
  EXPECT_TRUE(projectToGrid(m, 10.0, 11.0).cells.empty());
}

}  // namespace
}  // namespace densemap::map
