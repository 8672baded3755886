// Map queries and their answers as plain C++ types: what MapService::answer() takes and returns. The
// edges (DDS, ROS 2) convert their messages to and from these, in one wire file each.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "densemap/geometry/voxel_key.h"
#include "densemap/server/status.h"

namespace densemap::server {

using geometry::Vec3f;

/// Which layer answers: the exact map, the dense layer (Ch. 3), or the exact map where it observed the
/// cell and the dense layer elsewhere.
enum class Layer : std::uint8_t { kOccupancy, kDense, kFused };

struct PointsQuery {
  std::vector<Vec3f> points;  ///< world frame
  Layer layer = Layer::kOccupancy;
};
/// Occupied cells inside an axis-aligned box.
struct BoxQuery {
  Vec3f min = Vec3f::Zero(), max = Vec3f::Zero();
  std::uint32_t limit = 0;  ///< most cells returned (0: the server's default)
  Layer layer = Layer::kOccupancy;
};
/// The first occupied cell along a ray.
struct RayQuery {
  Vec3f origin = Vec3f::Zero(), direction = Vec3f::UnitX();
  float max_range = 0.0f;
  bool ignore_unknown = false;  ///< true: unknown cells do not stop the ray
  Layer layer = Layer::kOccupancy;
};
/// The map's statistics (iterates every cell).
struct StatsQuery {};

using Query = std::variant<PointsQuery, BoxQuery, RayQuery, StatsQuery>;

/// Cheap enough to answer on the transport's receive thread (a thread hand-over costs about the round
/// trip's tail on a loaded machine); the rest go to the edge's query threads.
bool answerInline(const Query& q);

/// kNotInMemory: the cell's block is stored out of memory (map window); its value is not known
/// here until a scan brings it back.
enum class CellState : std::uint8_t { kUnknown, kFree, kOccupied, kNotInMemory };

struct PointsAnswer {
  std::vector<float> probabilities;  ///< one per point; 0.5 for unknown
  std::vector<CellState> states;
};
struct BoxAnswer {
  std::vector<Vec3f> cells;  ///< centres of occupied cells
  bool truncated = false;    ///< more cells than the limit
  /// Map blocks in the box stored out of memory (map window): their cells are not in `cells`.
  std::uint32_t blocks_not_in_memory = 0;
};
struct RayAnswer {
  bool hit = false;
  Vec3f hit_point = Vec3f::Zero();  ///< centre of the hit cell
  /// The ray stopped at a block stored out of memory (map window): nothing is known from there on, even
  /// with ignore_unknown (an obstacle may be stored there).
  bool reached_not_in_memory = false;
  /// When reached_not_in_memory: the centre of the first cell stored out of memory (the service loads its
  /// block from there with --window-query-load-s).
  Vec3f not_in_memory_at = Vec3f::Zero();
};
/// A map's figures (StatsQuery, and what a save wrote).
struct MapSummary {
  std::string backend;
  double resolution = 0.0;
  std::uint64_t map_version = 0;
  std::uint64_t known_cells = 0;
  std::uint64_t occupied_cells = 0;
  std::uint64_t memory_bytes = 0;
  Vec3f bounds_min = Vec3f::Zero(), bounds_max = Vec3f::Zero();
};

struct Answer {
  Status status = Status::kOk;
  std::string message;
  std::uint64_t map_version = 0;  ///< the map state the answer was read from
  std::variant<std::monostate, PointsAnswer, BoxAnswer, RayAnswer, MapSummary> result;
};

}  // namespace densemap::server
