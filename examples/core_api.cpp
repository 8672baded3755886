// The C++ core without DDS: build a map from scans in-process and read it back.
#include <cmath>
#include <cstdio>
#include <optional>
#include <vector>

#include "densemap/map/map_factory.h"
#include "densemap/update/update_engine.h"

int main() {
  using namespace densemap;
  map::MapOptions map_options;  // the grid backend at 0.1 m, OctoMap's sensor model
  map_options.resolution = 0.1;
  const auto map = map::makeMap(map_options);
  update::UpdateEngine engine;  // the fastest exact method for each scan (Ch. 2)
  for (int scan = 0; scan < 10; ++scan) {
    const geometry::Vec3f origin(0.2f * float(scan), 0.f, 1.5f);
    std::vector<geometry::Vec3f> points;  // world frame
    for (int i = 0; i < 3600; ++i) {
      const float a = 0.1f * float(i) * 3.14159265f / 180.f;
      points.push_back(origin +
                       geometry::Vec3f(6.f * std::cos(a), 6.f * std::sin(a), 0.5f * float(i % 5) - 2.5f));
    }
    if (engine.insert(*map, points, origin)) std::printf("scan %d: %zu rays\n", scan, points.size());
  }
  geometry::VoxelKey key;
  std::optional<float> log_odds;  // none: unknown
  if (map->converter().toKey(geometry::Vec3f(6.f, 0.f, 0.f), key)) log_odds = map->logOdds(key);
  std::printf("%zu known cells; (6, 0, 0) is %s\n", map->knownCells(),
              !log_odds       ? "unknown"
              : *log_odds > 0 ? "occupied"
                              : "free");
  return 0;
}
