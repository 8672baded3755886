#include "densemap/update/super_ray_generator.h"

#include <parallel/algorithm>

#include <algorithm>
#include <unordered_map>

#include "densemap/geometry/ray_traversal.h"
#include "densemap/update/mapping_line.h"

namespace densemap::update {

namespace {

/// True when OctoMap's walk of this ray ends exactly at its endpoint cell with margin, i.e. rounding cannot
/// make it stop a cell early or late. Members of a super ray must satisfy it, as its end is shared.
bool endIsRobust(const geometry::RaySetup& r) {
  const double length = r.length;
  const double tol = 1e-9 * (length + 1.0);
  for (int i = 0; i < 3; ++i) {
    const int diff = static_cast<int>(r.end_key[i]) - static_cast<int>(r.origin_key[i]);
    if (r.step[i] == 0) {
      if (diff != 0) return false;
      continue;
    }
    const int k = diff * r.step[i];
    if (k < 0) return false;
    if (!(r.t_max0[i] + k * r.t_delta[i] > length + tol)) return false;
    if (k > 0 && !(r.t_max0[i] + (k - 1) * r.t_delta[i] < length - tol)) return false;
  }
  return true;
}

struct Segments {
  int xy, yz, zx;
  bool operator==(const Segments&) const = default;
};
struct SegmentsHash {
  std::size_t operator()(const Segments& s) const noexcept {
    return static_cast<std::size_t>(s.xy) * 1000003u ^ static_cast<std::size_t>(s.yz) * 7919u ^
           static_cast<std::size_t>(s.zx);
  }
};

}  // namespace

std::vector<SuperRay> SuperRayGenerator::generate(const geometry::KeyConverter& conv, const Vec3f& origin,
                                                  const std::vector<Vec3f>& ends, SuperRayStats* stats) const {
  VoxelKey ok;
  std::vector<SuperRay> out;
  if (!conv.toKey(origin, ok)) return out;

  // Group the rays by end cell (sort by packed key, then index, for a deterministic order).
  std::vector<std::pair<std::uint64_t, std::uint32_t>> order(ends.size());
#pragma omp parallel for schedule(static)
  for (std::size_t i = 0; i < ends.size(); ++i) {
    VoxelKey k;
    conv.toKey(ends[i], k);
    order[i] = {k.packed(), static_cast<std::uint32_t>(i)};
  }
  __gnu_parallel::sort(order.begin(), order.end());
  std::vector<std::size_t> group_begin;
  for (std::size_t i = 0; i < order.size(); ++i)
    if (i == 0 || order[i].first != order[i - 1].first) group_begin.push_back(i);
  group_begin.push_back(order.size());
  const std::size_t groups = group_begin.size() - 1;

  const GridPlanes planes[3] = {GridPlanes(conv, ok[0]), GridPlanes(conv, ok[1]), GridPlanes(conv, ok[2])};
  const double o[3] = {origin.x(), origin.y(), origin.z()};

  std::vector<std::vector<SuperRay>> per_group(groups);
  std::uint64_t unsafe = 0;
#pragma omp parallel for schedule(dynamic, 64) reduction(+ : unsafe)
  for (std::size_t g = 0; g < groups; ++g) {
    const std::size_t b = group_begin[g], e = group_begin[g + 1];
    auto& rays = per_group[g];
    if (e - b < options_.threshold || e - b < 2) {
      for (std::size_t i = b; i < e; ++i) rays.push_back({ends[order[i].second], 1});
      continue;
    }
    const VoxelKey ck = VoxelKey::fromPacked(order[b].first);
    // Alg. 2: three mapping lines, one per 2D sub-space.
    MappingLine xy, yz, zx;
    xy.build(o[0], o[1], ok[0], ok[1], ck[0], ck[1], planes[0], planes[1]);
    yz.build(o[1], o[2], ok[1], ok[2], ck[1], ck[2], planes[1], planes[2]);
    zx.build(o[2], o[0], ok[2], ok[0], ck[2], ck[0], planes[2], planes[0]);
    std::unordered_map<Segments, std::size_t, SegmentsHash> index;
    for (std::size_t i = b; i < e; ++i) {
      const Vec3f& p = ends[order[i].second];
      const double px = p.x(), py = p.y(), pz = p.z();
      const Segments s{xy.classify(px, py), yz.classify(py, pz), zx.classify(pz, px)};
      geometry::RaySetup setup;
      const bool safe = s.xy >= 0 && s.yz >= 0 && s.zx >= 0 && geometry::setupRay(conv, origin, p, setup) &&
                        endIsRobust(setup);
      if (!safe) {
        ++unsafe;
        rays.push_back({p, 1});
        continue;
      }
      auto [it, inserted] = index.try_emplace(s, rays.size());
      if (inserted) {
        rays.push_back({p, 1});
      } else {
        ++rays[it->second].weight;
      }
    }
  }
  std::size_t total = 0;
  for (const auto& r : per_group) total += r.size();
  out.reserve(total);
  SuperRayStats st;
  st.points = ends.size();
  st.unsafe = unsafe;
  for (const auto& r : per_group)
    for (const SuperRay& s : r) {
      out.push_back(s);
      if (s.weight > 1) {
        ++st.super_rays;
        st.grouped_points += s.weight;
      }
    }
  st.rays = out.size();
  if (stats) *stats = st;
  return out;
}

}  // namespace densemap::update
