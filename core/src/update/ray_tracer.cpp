#include "densemap/update/ray_tracer.h"

#include <algorithm>
#include <bit>
#include <cstdlib>

#include "densemap/geometry/ray_traversal.h"

namespace densemap::update {

using geometry::RaySetup;
using geometry::Vec3f;
using geometry::VoxelKey;
using geometry::WalkEnd;

namespace {

/// What one thread accumulates while walking.
template <bool kCountUnnecessary, bool kCounting>
struct Marker {
  const map::OccupancyMap& map;
  map::EvidenceCursor cursor;
  std::uint64_t visits = 0, useless = 0;
  Marker(const map::OccupancyMap& m, map::ScanEvidence& ev) : map(m), cursor(ev) {}
  [[gnu::always_inline]] void operator()(const VoxelKey& k, std::uint32_t weight) {
    ++visits;
    if constexpr (kCountUnnecessary) useless += map.isFullyFree(k) ? 1 : 0;
    if constexpr (kCounting) {
      cursor.addFree(k, weight);
    } else {
      cursor.markFree(k);
    }
  }
};

/// Batch semantics, forward walk, the baseline's hot loop: the DDA of geometry::walkForward (the same
/// arithmetic, comparisons and end tests, so the same cells as OctoMap's computeRayKeys), specialised by the
/// ray's step signs so that marking a cell costs no table lookups. The cell's Morton index inside its block
/// is stepped incrementally (a masked add on the stepped axis' interleaved bits), and the block is looked up
/// again only when a step leaves it, one step in 16 per axis.
class FreeMarkingWalk {
 public:
  explicit FreeMarkingWalk(map::ScanEvidence& ev) : ev_(ev) {}

  template <int kSx, int kSy, int kSz>
  std::uint64_t walk(const RaySetup& r) {
    if (r.origin_key == r.end_key) return 0;
    double tx = r.t_max0[0], ty = r.t_max0[1], tz = r.t_max0[2];
    const double dx = r.t_delta[0], dy = r.t_delta[1], dz = r.t_delta[2];
    int kx = r.origin_key[0], ky = r.origin_key[1], kz = r.origin_key[2];
    const int ex = r.end_key[0], ey = r.end_key[1], ez = r.end_key[2];
    const double length = r.length;
    enterBlock(kx, ky, kz);
    unsigned m = static_cast<unsigned>(map::voxelIndexInBlock(r.origin_key));
    mark(m, kx, ky, kz);
    std::uint64_t visits = 1;
    while (true) {
      if (tx < ty) {
        if (tx < tz) {
          step<kSx, kMortonX>(kx, m, kx, ky, kz);
          tx += dx;
        } else {
          step<kSz, kMortonZ>(kz, m, kx, ky, kz);
          tz += dz;
        }
      } else if (ty < tz) {
        step<kSy, kMortonY>(ky, m, kx, ky, kz);
        ty += dy;
      } else {
        step<kSz, kMortonZ>(kz, m, kx, ky, kz);
        tz += dz;
      }
      if (kx == ex && ky == ey && kz == ez) break;
      if (std::min(std::min(tx, ty), tz) > length) break;
      mark(m, kx, ky, kz);
      ++visits;
    }
    return visits;
  }

 private:
  // Bits of each axis in a block's Morton index (x in the lowest bit, see map::voxelIndexInBlock).
  static constexpr unsigned kMortonX = 0x249, kMortonY = kMortonX << 1, kMortonZ = kMortonX << 2;
  static_assert(map::kBlockShift == 4, "the Morton masks assume 16^3 blocks");

  template <int kS, unsigned kMask>
  [[gnu::always_inline]] void step(int& k, unsigned& m, const int& kx, const int& ky, const int& kz) {
    // A step of -1 is a masked decrement, of +1 a masked increment; both wrap at the block's side, which
    // is exactly when the block changes. (A zero step never happens: its tMax stays at DBL_MAX.)
    if constexpr (kS < 0) {
      k -= 1;
      m = (m & ~kMask) | (((m & kMask) - 1u) & kMask);
      if ((k & (map::kBlockSide - 1)) == map::kBlockSide - 1) [[unlikely]]
        enterBlock(kx, ky, kz);
    } else {
      k += 1;
      m = (m & ~kMask) | (((m | ~kMask) + 1u) & kMask);
      if ((k & (map::kBlockSide - 1)) == 0) [[unlikely]]
        enterBlock(kx, ky, kz);
    }
  }
  [[gnu::always_inline]] void enterBlock(int kx, int ky, int kz) {
    map::EvidenceBlock* b = ev_.findBlock(key(kx, ky, kz));
    plane_ = b ? &b->free : nullptr;
  }
  [[gnu::always_inline]] void mark(unsigned m, int kx, int ky, int kz) {
    if (plane_ != nullptr) [[likely]] {
      plane_->setAtomic(static_cast<int>(m));
    } else {
      markSlow(kx, ky, kz);
    }
  }
  /// First mark in a block this scan (allocates it), or a cell outside the scan's box (overflow map).
  [[gnu::noinline, gnu::cold]] void markSlow(int kx, int ky, int kz) {
    const VoxelKey k = key(kx, ky, kz);
    if (map::EvidenceBlock* b = ev_.block(k)) {
      plane_ = &b->free;
      plane_->setAtomic(map::voxelIndexInBlock(k));
    } else {
      ev_.markFree(k);
    }
  }
  static VoxelKey key(int kx, int ky, int kz) {
    return VoxelKey{{static_cast<geometry::KeyCoord>(kx), static_cast<geometry::KeyCoord>(ky),
                     static_cast<geometry::KeyCoord>(kz)}};
  }

  map::ScanEvidence& ev_;
  map::BitPlane* plane_ = nullptr;
};

/// Dispatches to the walk specialised for the ray's step signs (a zero step takes the + variant).
inline std::uint64_t markFreeForward(FreeMarkingWalk& w, const RaySetup& r) {
  switch ((r.step[0] < 0 ? 1 : 0) | (r.step[1] < 0 ? 2 : 0) | (r.step[2] < 0 ? 4 : 0)) {
    case 0:
      return w.walk<1, 1, 1>(r);
    case 1:
      return w.walk<-1, 1, 1>(r);
    case 2:
      return w.walk<1, -1, 1>(r);
    case 3:
      return w.walk<-1, -1, 1>(r);
    case 4:
      return w.walk<1, 1, -1>(r);
    case 5:
      return w.walk<-1, 1, -1>(r);
    case 6:
      return w.walk<1, -1, -1>(r);
    default:
      return w.walk<-1, -1, -1>(r);
  }
}

/// The sample is chosen by the ray's endpoint, not its position in `rays`, so it does not depend on the
/// order in which threads produced the rays (the statistics are reproducible, not only the map).
inline bool inSample(const Vec3f& end, std::size_t every) {
  std::uint64_t h = std::bit_cast<std::uint32_t>(end.x()) * 0x9E3779B97F4A7C15ULL;
  h ^= std::bit_cast<std::uint32_t>(end.y()) * 0xC2B2AE3D27D4EB4FULL;
  h ^= std::bit_cast<std::uint32_t>(end.z()) * 0x165667B19E3779F9ULL;
  return (h >> 29) % every == 0;
}

template <bool kCountUnnecessary, bool kCounting, bool kBackward, bool kRegion>
TraceCounters traceEach(const map::OccupancyMap& map, map::ScanEvidence& ev, const Vec3f& origin,
                        const std::vector<SuperRay>& rays, const TraceOptions& o) {
  const bool closed = o.stop_at_closed;
  const std::size_t every = std::max<std::size_t>(o.sample_every, 1);
  const auto subset = o.subset;
  const auto& conv = map.converter();
  std::uint64_t traversed = 0, fallbacks = 0, unnecessary = 0;
#pragma omp parallel reduction(+ : traversed, fallbacks, unnecessary)
  {
    Marker<kCountUnnecessary, kCounting> mark(map, ev);
    [[maybe_unused]] FreeMarkingWalk fast(ev);
    geometry::WalkStats ws;
#pragma omp for schedule(dynamic, 256) nowait
    for (std::size_t i = 0; i < rays.size(); ++i) {
      if (subset != TraceOptions::Subset::kAll &&
          (inSample(rays[i].end, every) != (subset == TraceOptions::Subset::kSample)))
        continue;
      const SuperRay& r = rays[i];
      RaySetup setup;
      if (!geometry::setupRay(conv, origin, r.end, setup)) continue;
      auto visit = [&](const VoxelKey& k) { mark(k, r.weight); };
      if constexpr (kBackward) {
        if constexpr (kRegion) {
          geometry::walkBackward(
              setup,
              [&](const VoxelKey& k) {
                return closed ? mark.cursor.template has<&map::EvidenceBlock::closed>(k)
                              : mark.cursor.template has<&map::EvidenceBlock::region>(k);
              },
              visit, &ws);
        } else {
          geometry::walkBackward(
              setup, [](const VoxelKey&) { return false; }, visit, &ws);
        }
      } else if constexpr (!kCounting && !kCountUnnecessary) {
        mark.visits += markFreeForward(fast, setup);
      } else {
        geometry::walkForward(setup, visit);
      }
    }
    traversed += mark.visits;
    unnecessary += mark.useless;
    fallbacks += ws.fallbacks;
  }
  return {traversed, fallbacks, unnecessary};
}

template <bool kCountUnnecessary, bool kCounting>
TraceCounters dispatch(const map::OccupancyMap& map, map::ScanEvidence& ev, const Vec3f& origin,
                       const std::vector<SuperRay>& rays, const TraceOptions& o) {
  if (!o.backward) return traceEach<kCountUnnecessary, kCounting, false, false>(map, ev, origin, rays, o);
  return o.region ? traceEach<kCountUnnecessary, kCounting, true, true>(map, ev, origin, rays, o)
                  : traceEach<kCountUnnecessary, kCounting, true, false>(map, ev, origin, rays, o);
}

}  // namespace

TraceCounters traceRays(const map::OccupancyMap& map, map::ScanEvidence& ev, const Vec3f& origin,
                        const std::vector<SuperRay>& rays, const TraceOptions& o) {
  if (o.count_unnecessary) {
    return o.counting ? dispatch<true, true>(map, ev, origin, rays, o)
                      : dispatch<true, false>(map, ev, origin, rays, o);
  }
  return o.counting ? dispatch<false, true>(map, ev, origin, rays, o)
                    : dispatch<false, false>(map, ev, origin, rays, o);
}

}  // namespace densemap::update
