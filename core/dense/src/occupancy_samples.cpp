#include "densemap/dense/occupancy_samples.h"

#include <algorithm>
#include <cmath>
#include <unordered_set>

namespace densemap::dense {

std::size_t SampleSet::occupiedCount() const {
  return static_cast<std::size_t>(std::count(occupied.begin(), occupied.end(), std::uint8_t{1}));
}

SampleSet sampleScan(const std::vector<Vec3f>& points, const Vec3f& origin, const SamplingOptions& o,
                     std::mt19937_64& rng) {
  SampleSet out;
  if (!origin.allFinite()) return out;
  const geometry::KeyConverter conv(o.resolution);
  const geometry::KeyConverter free_conv(o.free_voxel_size > 0 ? o.free_voxel_size : o.resolution);
  const float d = static_cast<float>(o.free_sample_distance);
  const float margin = static_cast<float>(0.5 * o.resolution);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  std::unordered_set<std::uint64_t> voxels, cut_voxels, free_voxels;
  voxels.reserve(points.size());
  out.add(origin, false, 0.0f);  // the sensor's own position is free
  for (const Vec3f& p : points) {
    if (!p.allFinite()) continue;
    Vec3f dir = p - origin;
    float length = dir.norm();
    if (length <= 0.0f) continue;
    dir /= length;
    bool hit = true;
    if (o.max_range >= 0 && length > o.max_range) {
      length = static_cast<float>(o.max_range);
      hit = false;
    }
    {
      // One occupied sample per voxel; with one_ray_per_voxel, only that point's ray gives free samples
      // (rays to one voxel are nearly the same ray).
      geometry::VoxelKey k;
      const Vec3f end = hit ? p : Vec3f(origin + dir * length);
      const bool first = conv.toKey(end, k) && (hit ? voxels : cut_voxels).insert(k.packed()).second;
      if (hit && first) out.add(p, true, length);
      if (o.one_ray_per_voxel && !first) continue;
    }
    // One free sample per segment [k d, (k+1) d) of the ray, short of the endpoint's voxel.
    const float free_end = hit ? length - margin : length;
    for (float start = 0.0f; start < free_end; start += d) {
      const float end = std::min(start + d, free_end);
      const float t = start + unit(rng) * (end - start);
      const Vec3f q = origin + dir * t;
      if (o.one_free_sample_per_voxel) {
        // Rays converge near the sensor: one free sample per voxel keeps that region from being sampled
        // thousands of times over (and its neighbour searches from going quadratic).
        geometry::VoxelKey k;
        if (!free_conv.toKey(q, k) || !free_voxels.insert(k.packed()).second) continue;
      }
      out.add(q, false, t);
    }
  }
  return out;
}

}  // namespace densemap::dense
