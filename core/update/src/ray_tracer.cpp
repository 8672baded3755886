#include "densemap/update/ray_tracer.h"

#include <algorithm>
#include <bit>
#include <cstdlib>

#include <omp.h>

#include "batch_marking_walk.h"
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

/// The sample is chosen by the ray's endpoint, not its position in `rays`, so it does not depend on the
/// order in which threads produced the rays (the statistics are reproducible, not only the map).
inline bool inSample(const Vec3f& end, std::size_t every) {
  std::uint64_t h = std::bit_cast<std::uint32_t>(end.x()) * 0x9E3779B97F4A7C15ULL;
  h ^= std::bit_cast<std::uint32_t>(end.y()) * 0xC2B2AE3D27D4EB4FULL;
  h ^= std::bit_cast<std::uint32_t>(end.z()) * 0x165667B19E3779F9ULL;
  return (h >> 29) % every == 0;
}

/// The rays to walk: super rays (end and weight), or the endpoints of a scan, each a ray of weight 1 (the
/// preparation's output when it rejected and cut nothing, walked without copying it into super rays).
struct SuperRayList {
  const std::vector<SuperRay>& rays;
  std::size_t size() const { return rays.size(); }
  const Vec3f& end(std::size_t i) const { return rays[i].end; }
  std::uint32_t weight(std::size_t i) const { return rays[i].weight; }
};
struct EndpointList {
  const std::vector<Vec3f>& ends;
  std::size_t size() const { return ends.size(); }
  const Vec3f& end(std::size_t i) const { return ends[i]; }
  std::uint32_t weight(std::size_t) const { return 1; }
};

template <bool kCountUnnecessary, bool kCounting, bool kBackward, bool kRegion, class Rays>
TraceCounters traceEach(const map::OccupancyMap& map, map::ScanEvidence& ev, const Vec3f& origin,
                        const Rays& rays, const TraceOptions& o) {
  const bool closed = o.stop_at_closed;
  const std::size_t every = std::max<std::size_t>(o.sample_every, 1);
  const auto subset = o.subset;
  const auto& conv = map.converter();
  std::uint64_t traversed = 0, fallbacks = 0, unnecessary = 0, hit_cells = 0, shared_walks = 0;
  VoxelKey origin_key;  // once per scan, not per ray
  const bool origin_ok = conv.toKey(origin, origin_key);
  const std::size_t known_keys = o.end_keys != nullptr ? std::min(o.end_keys->size(), rays.size()) : 0;
  auto setupAt = [&](std::size_t i, RaySetup& s) {
    if (i < known_keys) {
      geometry::setupRayWithKeys(conv, origin, origin_key, rays.end(i), (*o.end_keys)[i], s);
      return true;
    }
    return geometry::setupRay(conv, origin, origin_key, rays.end(i), s);
  };
  constexpr bool kPairs = !kCounting && !kCountUnnecessary && !kBackward;
  // The pair walks mark the endpoints' cells hit too (rays i < known_keys are the scan's endpoints).
  const bool marks_hits = kPairs && subset == TraceOptions::Subset::kAll && origin_ok;
#pragma omp parallel reduction(+ : traversed, fallbacks, unnecessary, hit_cells, shared_walks)
  {
    Marker<kCountUnnecessary, kCounting> mark(map, ev);
    [[maybe_unused]] BatchMarkingWalk fast(
        ev, BatchMarkingWalk::laneFor(omp_get_thread_num(), omp_get_num_threads()));
    geometry::WalkStats ws;
    // Batch semantics, forward, every ray: neighbouring rays (a ring's consecutive points) are walked in
    // pairs, sharing the steps while they are in the same cell (BatchMarkingWalk::forwardPair).
    if (kPairs && subset == TraceOptions::Subset::kAll) {
      const std::size_t n = rays.size();
#pragma omp for schedule(dynamic, 128) nowait
      for (std::size_t p = 0; p < (n + 1) / 2; ++p) {
        if (!origin_ok) continue;
        const std::size_t i = 2 * p;
        RaySetup sa, sb;
        const bool ok_a = setupAt(i, sa);
        const bool ok_b = i + 1 < n && setupAt(i + 1, sb);
        const bool hit_a = i < known_keys, hit_b = i + 1 < known_keys;
        if (ok_a && ok_b && sa.step[0] == sb.step[0] && sa.step[1] == sb.step[1] &&
            sa.step[2] == sb.step[2] && !(sa.end_key == origin_key) && !(sb.end_key == origin_key)) {
          mark.visits += withStepSigns(sa, [&]<int kSx, int kSy, int kSz>() {
            return fast.template forwardPair<kSx, kSy, kSz>(sa, sb, hit_a, hit_b);
          });
          continue;
        }
        auto single = [&](const RaySetup& s, bool hit) {
          mark.visits += withStepSigns(
              s, [&]<int kSx, int kSy, int kSz>() { return fast.template forward<kSx, kSy, kSz>(s, hit); });
        };
        if (ok_a) single(sa, hit_a);
        if (ok_b) single(sb, hit_b);
      }
    } else {
#pragma omp for schedule(dynamic, 256) nowait
      for (std::size_t i = 0; i < rays.size(); ++i) {
        if (subset != TraceOptions::Subset::kAll &&
            (inSample(rays.end(i), every) != (subset == TraceOptions::Subset::kSample)))
          continue;
        const std::uint32_t weight = rays.weight(i);
        RaySetup setup;
        if (!origin_ok || !setupAt(i, setup)) continue;
        auto visit = [&](const VoxelKey& k) { mark(k, weight); };
        auto in_region = [&](const VoxelKey& k) {
          if constexpr (!kRegion) return false;
          return closed ? mark.cursor.template has<&map::EvidenceBlock::closed>(k)
                        : mark.cursor.template has<&map::EvidenceBlock::region>(k);
        };
        if constexpr (!kCounting && !kCountUnnecessary) {
          // Batch semantics: the specialised walks (same cells, cheaper marking).
          if constexpr (kBackward) {
            auto fallback = [&](const VoxelKey& stop_key) {
              geometry::walkForward(setup, stop_key, in_region, visit);
              ++ws.fallbacks;
            };
            auto walk = [&]<StopAt kStop>() {
              return withStepSigns(setup, [&]<int kSx, int kSy, int kSz>() {
                return fast.template backward<kSx, kSy, kSz, kStop>(setup, fallback);
              });
            };
            if constexpr (kRegion) {
              mark.visits += closed ? walk.template operator()<StopAt::kClosed>()
                                    : walk.template operator()<StopAt::kRegion>();
            } else {
              mark.visits += walk.template operator()<StopAt::kNothing>();
            }
          } else {
            mark.visits += withStepSigns(setup, [&]<int kSx, int kSy, int kSz>() {
              return fast.template forward<kSx, kSy, kSz>(setup);
            });
          }
        } else if constexpr (kBackward) {
          geometry::walkBackward(setup, in_region, visit, &ws);
        } else {
          geometry::walkForward(setup, visit);
        }
      }
    }
    traversed += mark.visits;
    unnecessary += mark.useless;
    fallbacks += ws.fallbacks;
    hit_cells += fast.endCounts().first_hits;
    shared_walks += fast.endCounts().shared_walks;
  }
  if constexpr (!kCounting && !kCountUnnecessary) ev.mergeFreeLanes();
  TraceCounters c{traversed, fallbacks, unnecessary};
  c.hits_marked = marks_hits && o.end_keys != nullptr && known_keys == o.end_keys->size();
  c.hit_cells = hit_cells;
  c.shared_walks = shared_walks;
  return c;
}

template <bool kCountUnnecessary, bool kCounting, class Rays>
TraceCounters dispatch(const map::OccupancyMap& map, map::ScanEvidence& ev, const Vec3f& origin,
                       const Rays& rays, const TraceOptions& o) {
  if (!o.backward) return traceEach<kCountUnnecessary, kCounting, false, false>(map, ev, origin, rays, o);
  return o.region ? traceEach<kCountUnnecessary, kCounting, true, true>(map, ev, origin, rays, o)
                  : traceEach<kCountUnnecessary, kCounting, true, false>(map, ev, origin, rays, o);
}

template <class Rays>
TraceCounters traceAny(const map::OccupancyMap& map, map::ScanEvidence& ev, const Vec3f& origin,
                       const Rays& rays, const TraceOptions& o) {
  if (o.count_unnecessary) {
    return o.counting ? dispatch<true, true>(map, ev, origin, rays, o)
                      : dispatch<true, false>(map, ev, origin, rays, o);
  }
  return o.counting ? dispatch<false, true>(map, ev, origin, rays, o)
                    : dispatch<false, false>(map, ev, origin, rays, o);
}

}  // namespace

TraceCounters traceRays(const map::OccupancyMap& map, map::ScanEvidence& ev, const Vec3f& origin,
                        const std::vector<SuperRay>& rays, const TraceOptions& o) {
  return traceAny(map, ev, origin, SuperRayList{rays}, o);
}

TraceCounters traceRays(const map::OccupancyMap& map, map::ScanEvidence& ev, const Vec3f& origin,
                        const std::vector<Vec3f>& ends, const TraceOptions& o) {
  return traceAny(map, ev, origin, EndpointList{ends}, o);
}

}  // namespace densemap::update
