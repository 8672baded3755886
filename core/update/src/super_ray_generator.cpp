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
    // A cell's distinct regions in order of first appearance (and, for the assignment, its safe members as
    // (region, point) in point order). A cell holds a few regions (~13 points each on hilti2023 at 0.8 m), so
    // a linear search groups them; a counting pass then lists each region's members in point order. This
    // replaced a comparison sort of (three segments, point), the generator's largest cost on coarse grids.
    std::vector<std::uint32_t> member_region, member_point;  // filled only when tracking the assignment
    std::vector<std::uint32_t> region_count, region_first, region_start, members;
    std::vector<std::uint64_t> regions;
    std::vector<std::uint32_t> table;  // open addressing, region number + 1 (large cells only)
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
      member_region.clear();
      member_point.clear();
      regions.clear();
      region_count.clear();
      region_first.clear();
      // Small cells search their few regions; a large one (near the sensor, where points are many and
      // regions ~1 point each) would make that quadratic, so it hashes.
      const bool hashed = e - b > 64;
      std::uint64_t mask = 0;
      if (hashed) {
        table.assign(std::bit_ceil(2 * (e - b)), 0);
        mask = table.size() - 1;
      }
      for (std::size_t i = b; i < e; ++i) {
        const std::uint32_t idx = order_[i].second;
        const Vec3f& p = ends[idx];
        const double px = p.x(), py = p.y(), pz = p.z();
        const int s0 = xy.classify(px, py), s1 = yz.classify(py, pz), s2 = zx.classify(pz, px);
        geometry::RaySetup setup;
        bool safe = s0 >= 0 && s1 >= 0 && s2 >= 0;
        if (safe) {
          // ck is this end's cell and ok the origin's: the keys setupRay() would compute again.
          geometry::setupRayWithKeys(conv, origin, ok, p, ck, setup);
          safe = endIsRobust(setup);
        }
        if (!safe) {
          // Passes within rounding distance of a grid edge, or ends next to a cell face: its own walk.
          ++unsafe;
          rays.push_back({p, 1});
          if (track) first.push_back(idx);
          continue;
        }
        // A mapping line has fewer than 2^18 segments (16-bit keys), so 21 bits each hold them.
        const std::uint64_t region = (static_cast<std::uint64_t>(s0) << 42) |
                                     (static_cast<std::uint64_t>(s1) << 21) | static_cast<std::uint64_t>(s2);
        std::size_t r = 0;
        if (hashed) {
          std::uint64_t h = (region * 0x9E3779B97F4A7C15ull) >> 32;
          while (table[h & mask] != 0 && regions[table[h & mask] - 1] != region) ++h;
          if (table[h & mask] == 0) table[h & mask] = static_cast<std::uint32_t>(regions.size() + 1);
          r = table[h & mask] - 1;
        } else {
          while (r < regions.size() && regions[r] != region) ++r;
        }
        if (r == regions.size()) {
          regions.push_back(region);
          region_count.push_back(0);
          region_first.push_back(idx);
        }
        ++region_count[r];
        if (track) {
          member_region.push_back(static_cast<std::uint32_t>(r));
          member_point.push_back(idx);
        }
      }
      for (std::size_t r = 0; r < regions.size(); ++r)
        rays.push_back({ends[region_first[r]], region_count[r]});
      if (track) {
        // Each ray's first member, then (member, marker) pairs resolved below.
        region_start.assign(regions.size() + 1, 0);
        for (std::size_t r = 0; r < regions.size(); ++r)
          region_start[r + 1] = region_start[r] + region_count[r];
        members.resize(member_point.size());
        for (std::size_t m = 0; m < member_point.size(); ++m)
          members[region_start[member_region[m]]++] = member_point[m];
        std::size_t at = 0;
        for (std::size_t r = 0; r < regions.size(); ++r) {
          first.push_back(members[at++]);
          for (std::uint32_t k = 1; k < region_count[r]; ++k) {
            first.push_back(members[at++]);
            first.push_back(~std::uint32_t{0});
          }
        }
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
