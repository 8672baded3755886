#include "densemap/update/super_ray_generator.h"

#include <parallel/algorithm>

#include <omp.h>
#include <algorithm>
#include <array>
#include <bit>

#include "densemap/geometry/ray_traversal.h"
#include "densemap/update/mapping_line.h"

namespace densemap::update {

namespace {

/// True when OctoMap's walk of this ray ends exactly at its endpoint cell with margin, i.e. rounding cannot
/// make it stop a cell early or late. Members of a super ray must satisfy it, as its end is shared.
bool endIsRobust(const geometry::RaySetup& r) {
  geometry::BackwardStart unused;
  return geometry::backwardStart(r, r.end_key, true, unused);
}

struct Classified {
  int seg[3];
  std::uint32_t index;  // point index
  bool operator<(const Classified& o) const {
    if (seg[0] != o.seg[0]) return seg[0] < o.seg[0];
    if (seg[1] != o.seg[1]) return seg[1] < o.seg[1];
    if (seg[2] != o.seg[2]) return seg[2] < o.seg[2];
    return index < o.index;
  }
};

}  // namespace

void SuperRayGenerator::radixSortByCode(std::vector<CodedIndex>& a, std::vector<CodedIndex>& tmp, int bits) {
  // LSD, one byte per pass; stable, so equal codes keep their (point index) order.
  tmp.resize(a.size());
  for (int shift = 0; shift < bits; shift += 8) {
    std::array<std::uint32_t, 257> start{};
    for (const CodedIndex& x : a) ++start[((x.code >> shift) & 0xFFu) + 1];
    for (std::size_t d = 1; d < start.size(); ++d) start[d] += start[d - 1];
    for (const CodedIndex& x : a) tmp[start[(x.code >> shift) & 0xFFu]++] = x;
    a.swap(tmp);
  }
}

void SuperRayGenerator::generate(const geometry::KeyConverter& conv, const Vec3f& origin,
                                 const std::vector<Vec3f>& ends, std::vector<SuperRay>& out,
                                 SuperRayStats* stats, std::vector<std::uint32_t>* assignment,
                                 const std::vector<VoxelKey>* end_keys) {
  out.clear();
  VoxelKey ok;
  if (!conv.toKey(origin, ok)) return;

  // Group the rays by end cell: order by (end cell, point index), the cells in (x, y, z) order. A stable
  // radix sort of the cells' linear index in the scan's key box does it in a few passes; the comparison
  // sort it replaces took 3-4 ms per KITTI scan.
  const std::size_t n = ends.size();
  order_.resize(n);
  int lo[3] = {0xFFFF, 0xFFFF, 0xFFFF}, hi[3] = {0, 0, 0};
#pragma omp parallel for schedule(static) reduction(min : lo[:3]) reduction(max : hi[:3])
  for (std::size_t i = 0; i < n; ++i) {
    VoxelKey k;
    if (end_keys != nullptr) {
      k = (*end_keys)[i];
    } else {
      conv.toKey(ends[i], k);
    }
    order_[i] = {k.packed(), static_cast<std::uint32_t>(i)};
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min<int>(lo[a], k[a]);
      hi[a] = std::max<int>(hi[a], k[a]);
    }
  }
  std::uint64_t cells = 1;
  for (int a = 0; a < 3; ++a) cells *= static_cast<std::uint64_t>(std::max(hi[a] - lo[a] + 1, 1));
  if (n > 0 && cells <= (std::uint64_t{1} << 32)) {
    const std::uint64_t span_y = static_cast<std::uint64_t>(hi[1] - lo[1] + 1);
    const std::uint64_t span_z = static_cast<std::uint64_t>(hi[2] - lo[2] + 1);
    items_.resize(n);
#pragma omp parallel for schedule(static)
    for (std::size_t i = 0; i < n; ++i) {
      const VoxelKey k = VoxelKey::fromPacked(order_[i].first);
      const std::uint64_t code =
          (static_cast<std::uint64_t>(k[0] - lo[0]) * span_y + static_cast<std::uint64_t>(k[1] - lo[1])) *
              span_z +
          static_cast<std::uint64_t>(k[2] - lo[2]);
      items_[i] = {static_cast<std::uint32_t>(code), static_cast<std::uint32_t>(i)};
    }
    radixSortByCode(items_, items_tmp_, std::bit_width(cells - 1));
    sorted_.resize(n);
    for (std::size_t i = 0; i < n; ++i) sorted_[i] = order_[items_[i].index];
    order_.swap(sorted_);
  } else {
    __gnu_parallel::sort(order_.begin(), order_.end());
  }
  group_begin_.clear();
  for (std::size_t i = 0; i < order_.size(); ++i)
    if (i == 0 || order_[i].first != order_[i - 1].first) group_begin_.push_back(i);
  group_begin_.push_back(order_.size());
  const std::size_t groups = group_begin_.size() - 1;

  const GridPlanes planes[3] = {GridPlanes(conv, ok[0]), GridPlanes(conv, ok[1]), GridPlanes(conv, ok[2])};
  const double o[3] = {origin.x(), origin.y(), origin.z()};
  const std::uint32_t k_min = std::max<std::uint32_t>(options_.threshold, 2);

  std::uint64_t unsafe = 0;
#pragma omp parallel reduction(+ : unsafe)
  {
#pragma omp single
    {
      per_thread_.resize(static_cast<std::size_t>(omp_get_num_threads()));
      per_thread_first_.resize(per_thread_.size());
    }
    auto& rays = per_thread_[static_cast<std::size_t>(omp_get_thread_num())];
    auto& first = per_thread_first_[static_cast<std::size_t>(omp_get_thread_num())];
    rays.clear();
    first.clear();
    const bool track = assignment != nullptr;
    MappingLine xy, yz, zx;
    std::vector<Classified> cls;
#pragma omp for schedule(dynamic, 64) nowait
    for (std::size_t g = 0; g < groups; ++g) {
      const std::size_t b = group_begin_[g], e = group_begin_[g + 1];
      if (e - b < k_min) {
        for (std::size_t i = b; i < e; ++i) {
          rays.push_back({ends[order_[i].second], 1});
          if (track) first.push_back(order_[i].second);
        }
        continue;
      }
      const VoxelKey ck = VoxelKey::fromPacked(order_[b].first);
      // Alg. 2: three mapping lines, one per 2D sub-space; a ray's segments in the three (Eq. 2.6) name
      // its region of the mapping plane.
      xy.build(o[0], o[1], ok[0], ok[1], ck[0], ck[1], planes[0], planes[1]);
      yz.build(o[1], o[2], ok[1], ok[2], ck[1], ck[2], planes[1], planes[2]);
      zx.build(o[2], o[0], ok[2], ok[0], ck[2], ck[0], planes[2], planes[0]);
      cls.clear();
      for (std::size_t i = b; i < e; ++i) {
        const std::uint32_t idx = order_[i].second;
        const Vec3f& p = ends[idx];
        const double px = p.x(), py = p.y(), pz = p.z();
        const int s0 = xy.classify(px, py), s1 = yz.classify(py, pz), s2 = zx.classify(pz, px);
        geometry::RaySetup setup;
        const bool safe =
            s0 >= 0 && s1 >= 0 && s2 >= 0 && geometry::setupRay(conv, origin, p, setup) && endIsRobust(setup);
        if (!safe) {
          // Passes within rounding distance of a grid edge, or ends next to a cell face: its own walk.
          ++unsafe;
          rays.push_back({p, 1});
          if (track) first.push_back(idx);
          continue;
        }
        cls.push_back({{s0, s1, s2}, idx});
      }
      std::sort(cls.begin(), cls.end());
      for (std::size_t i = 0; i < cls.size();) {
        std::size_t j = i + 1;
        while (j < cls.size() && cls[j].seg[0] == cls[i].seg[0] && cls[j].seg[1] == cls[i].seg[1] &&
               cls[j].seg[2] == cls[i].seg[2])
          ++j;
        rays.push_back({ends[cls[i].index], static_cast<std::uint32_t>(j - i)});
        if (track) {
          // Members after the first are recorded as (member, -1 - ray) pairs resolved below.
          first.push_back(cls[i].index);
          for (std::size_t m = i + 1; m < j; ++m) {
            first.push_back(cls[m].index);
            first.push_back(~std::uint32_t{0});
          }
        }
        i = j;
      }
    }
  }
  if (assignment != nullptr) {
    // Walk each thread's records in step with its rays: a ray's first member, then (member, marker) pairs.
    assignment->assign(ends.size(), ~std::uint32_t{0});
    std::uint32_t ray = 0;
    for (std::size_t t = 0; t < per_thread_.size(); ++t) {
      const auto& f = per_thread_first_[t];
      std::size_t pos = 0;
      for (std::size_t r = 0; r < per_thread_[t].size(); ++r, ++ray) {
        (*assignment)[f[pos++]] = ray;
        while (pos + 1 < f.size() && f[pos + 1] == ~std::uint32_t{0}) {
          (*assignment)[f[pos]] = ray;
          pos += 2;
        }
      }
    }
  }
  std::size_t total = 0;
  for (const auto& r : per_thread_) total += r.size();
  out.reserve(total);
  SuperRayStats st;
  st.points = ends.size();
  st.unsafe = unsafe;
  for (const auto& r : per_thread_)
    for (const SuperRay& sr : r) {
      out.push_back(sr);
      if (sr.weight > 1) {
        ++st.super_rays;
        st.grouped_points += sr.weight;
      }
    }
  st.rays = out.size();
  if (stats) *stats = st;
}

}  // namespace densemap::update
