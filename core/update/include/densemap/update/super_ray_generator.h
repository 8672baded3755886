// Super rays (Sec. 2.3.2-2.3.4, Alg. 2): the points of one cell whose rays fall into the same segment
// of the three mapping lines (XY, YZ, ZX sub-spaces) traverse identical cells, so one traversal weighted by
// their count replaces them.
#pragma once

#include <cstdint>
#include <vector>

#include "densemap/geometry/voxel_key.h"

namespace densemap::update {

using geometry::Vec3f;
using geometry::VoxelKey;

struct SuperRayOptions {
  /// Minimum number of points in a cell for building super rays (Sec. 2.4, "k"); sparser cells keep their
  /// rays single, since grouping them would cost more than it saves. The dissertation uses 20.
  std::uint32_t threshold = 20;
};

/// A ray to traverse from the sensor: its end (a member's endpoint) and how many rays it stands for.
struct SuperRay {
  Vec3f end;
  std::uint32_t weight;
};

struct SuperRayStats {
  std::uint64_t points = 0;          ///< rays given to the generator
  std::uint64_t rays = 0;            ///< rays to traverse after grouping (super rays + single rays)
  std::uint64_t grouped_points = 0;  ///< points represented by super rays of weight > 1
  std::uint64_t super_rays = 0;      ///< rays of weight > 1
  std::uint64_t unsafe = 0;          ///< points kept single because they pass within tolerance of a grid edge
};

class SuperRayGenerator {
 public:
  explicit SuperRayGenerator(SuperRayOptions options = {}) : options_(options) {}

  /// Groups rays from `origin` to `ends` (world frame; each end inside the key range) into `out`
  /// (cleared first). Rays whose ends share a cell and a mapping-plane region become one super ray. The
  /// generator keeps its buffers between calls, so steady state allocates nothing.
  /// If `assignment` is given, it receives for every end the index in `out` of the super ray standing for it.
  /// `end_keys`, when given, are the ends' cells (conv.toKey of each end), which the caller already has.
  void generate(const geometry::KeyConverter& conv, const Vec3f& origin, const std::vector<Vec3f>& ends,
                std::vector<SuperRay>& out, SuperRayStats* stats = nullptr,
                std::vector<std::uint32_t>* assignment = nullptr,
                const std::vector<geometry::VoxelKey>* end_keys = nullptr);
  /// Convenience form returning a new vector.
  std::vector<SuperRay> generate(const geometry::KeyConverter& conv, const Vec3f& origin,
                                 const std::vector<Vec3f>& ends, SuperRayStats* stats = nullptr) {
    std::vector<SuperRay> out;
    generate(conv, origin, ends, out, stats);
    return out;
  }

  const SuperRayOptions& options() const { return options_; }
  void setOptions(const SuperRayOptions& o) { options_ = o; }

 private:
  SuperRayOptions options_;
  struct CodedIndex {
    std::uint32_t code;   // end cell's linear index in the scan's key box
    std::uint32_t index;  // point index
  };
  static void radixSortByCode(std::vector<CodedIndex>& a, std::vector<CodedIndex>& tmp, int bits);
  std::vector<std::pair<std::uint64_t, std::uint32_t>> order_, sorted_;  // (end cell, point index)
  std::vector<CodedIndex> items_, items_tmp_;
  std::vector<std::size_t> group_begin_;
  std::vector<std::vector<SuperRay>> per_thread_;
  std::vector<std::vector<std::uint32_t>> per_thread_first_;  // first member of each ray (for assignment)
};

}  // namespace densemap::update
