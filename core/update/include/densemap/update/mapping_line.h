// The mapping line of Sec. 2.3.1 (Alg. 1): for one cell seen from the sensor in a 2D sub-space, the sorted
// projections of every grid point inside the seed frustum. Rays falling into the same segment between two
// consecutive projections cross the grid lines in the same order, so they traverse the same cells
// (Theorem 1). Projections are stored as slopes v/u relative to the origin, i.e. the coordinates of the
// points on a mapping line at unit distance along the processing axis (Eq. 2.3-2.5).
#pragma once

#include <cstdint>
#include <vector>

#include "densemap/geometry/voxel_key.h"

namespace densemap::update {

/// Relative tolerance below which a ray counts as passing through a grid point: the endpoint-derived slope
/// and OctoMap's float direction differ by a few float ulps (~1e-7), so such rays are kept single.
inline constexpr double kSlopeTolerance = 1e-6;

/// Grid planes as OctoMap's DDA places them for rays leaving `origin_key`: planes ahead of the origin
/// cell in the ray's direction start at keyToCoord(origin) +/- (float)(res/2) and repeat every res.
struct GridPlanes {
  double resolution;
  double origin_center;  ///< keyToCoord(origin key)
  double half_up;        ///< (float)(+res/2)
  double half_down;      ///< (float)(-res/2)
  int origin_key;

  GridPlanes(const geometry::KeyConverter& conv, int origin_key_coord);
  /// Coordinate of the plane between keys n-1 and n.
  double plane(int n) const {
    return n > origin_key ? origin_center + half_up + static_cast<double>(n - origin_key - 1) * resolution
                          : origin_center + half_down - static_cast<double>(origin_key - n) * resolution;
  }
};

class MappingLine {
 public:
  /// Builds the line for the cell with keys (cell_u, cell_v) seen from origin (ou, ov) whose keys are
  /// (origin_u, origin_v); `pu`, `pv` give the grid planes along the two axes.
  void build(double ou, double ov, int origin_u, int origin_v, int cell_u, int cell_v, const GridPlanes& pu,
             const GridPlanes& pv);

  /// Segment index of a ray ending at (u, v), per Eq. 2.6 ([x_i, x_{i+1})), or -1 when the ray passes
  /// within tolerance of a projected grid point (its traversal could differ in floating point).
  int classify(double u, double v) const;

  /// Number of segments (projected grid points + 1).
  std::size_t segments() const { return slopes_.size() + 1; }
  const std::vector<double>& projections() const { return slopes_; }

 private:
  double ou_ = 0.0, ov_ = 0.0;
  bool swapped_ = false;  // processing axis is v
  bool trivial_ = true;   // origin and cell share both keys: a single segment
  std::vector<double> slopes_;
};

}  // namespace densemap::update
