// Occupancy samples from one scan (Sec. 3.3.2): occupied samples are the scan's points, one per voxel;
// free samples are one uniformly random point per free-sample distance along each ray, plus the sensor
// origin. Seeded, so a run can be repeated.
#pragma once

#include <cstdint>
#include <random>
#include <vector>

#include "densemap/geometry/voxel_key.h"

namespace densemap::dense {

using geometry::Vec3f;

struct SamplingOptions {
  /// Occupied samples keep one scan point per voxel of this size (metres); usually the map resolution.
  double resolution = 0.1;
  /// One free sample per this many metres of each ray (the dissertation and BGKOctoMap: 0.5 m).
  double free_sample_distance = 0.5;
  /// Rays longer than this are cut there and give no occupied sample; < 0: unlimited.
  double max_range = -1.0;
  /// Keep at most one free sample per voxel of `free_voxel_size` (0: `resolution`) per scan: rays converge
  /// near the sensor, which would otherwise be sampled thousands of times over.
  bool one_free_sample_per_voxel = true;
  double free_voxel_size = 0.0;
  /// Free samples only along the rays of the points kept as occupied samples (one ray per voxel).
  bool one_ray_per_voxel = true;
};

struct SampleSet {
  std::vector<Vec3f> points;
  std::vector<std::uint8_t> occupied;  ///< 1 occupied, 0 free
  std::vector<float> range;            ///< distance from the sensor (sets the neighbour search radius)
  std::size_t size() const { return points.size(); }
  std::size_t occupiedCount() const;
  void clear() {
    points.clear();
    occupied.clear();
    range.clear();
  }
  void add(const Vec3f& p, bool occ, float r) {
    points.push_back(p);
    occupied.push_back(occ ? 1 : 0);
    range.push_back(r);
  }
};

/// Samples of one scan (world-frame points, sensor origin). Non-finite points are skipped. Free samples
/// stop half a voxel before the endpoint so they never share the occupied sample's voxel.
SampleSet sampleScan(const std::vector<Vec3f>& points, const Vec3f& origin, const SamplingOptions& options,
                     std::mt19937_64& rng);

}  // namespace densemap::dense
