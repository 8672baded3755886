#include "densemap/update/update_engine.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "densemap/geometry/ray_traversal.h"
#include "densemap/update/culling_region.h"

namespace densemap::update {

using geometry::Vec3f;
using geometry::VoxelKey;
using map::UpdateSemantics;

std::string_view toString(UpdateMethod m) {
  switch (m) {
    case UpdateMethod::kBaseline:
      return "baseline";
    case UpdateMethod::kSuperRays:
      return "superrays";
    case UpdateMethod::kCullingRegion:
      return "culling";
    case UpdateMethod::kSuperRaysCulling:
      return "superrays+culling";
  }
  return "?";
}

std::optional<UpdateMethod> parseMethod(std::string_view s) {
  for (UpdateMethod m : kAllMethods)
    if (toString(m) == s) return m;
  if (s == "default" || s == "ours") return UpdateMethod::kSuperRaysCulling;
  return std::nullopt;
}

UpdateEngine::UpdateEngine(UpdateOptions options) : options_(options) {}

template <bool kCountUnnecessary, bool kCounting, bool kBackward, bool kRegion>
UpdateEngine::TraceCounters UpdateEngine::traceRaysImpl(const map::OccupancyMap& map, const Vec3f& origin,
                                                        const std::vector<SuperRay>& rays) {
  const auto& conv = map.converter();
  std::uint64_t traversed = 0, fallbacks = 0, unnecessary = 0;
  map::ScanEvidence& ev = evidence_;
#pragma omp parallel reduction(+ : traversed, fallbacks, unnecessary)
  {
    map::EvidenceCursor cursor(ev);
    std::uint64_t visits = 0, useless = 0;
    geometry::WalkStats ws;
#pragma omp for schedule(dynamic, 256) nowait
    for (std::size_t i = 0; i < rays.size(); ++i) {
      const SuperRay& r = rays[i];
      geometry::RaySetup setup;
      if (!geometry::setupRay(conv, origin, r.end, setup)) continue;
      auto visit = [&](const VoxelKey& k) {
        ++visits;
        if constexpr (kCountUnnecessary) useless += map.isFullyFree(k) ? 1 : 0;
        if constexpr (kCounting) {
          cursor.addFree(k, r.weight);
        } else {
          cursor.markFree(k);
        }
      };
      if constexpr (kBackward) {
        if constexpr (kRegion) {
          geometry::walkBackward(setup, [&](const VoxelKey& k) { return cursor.inRegion(k); }, visit, &ws);
        } else {
          geometry::walkBackward(setup, [](const VoxelKey&) { return false; }, visit, &ws);
        }
      } else {
        geometry::walkForward(setup, visit);
      }
    }
    traversed += visits;
    unnecessary += useless;
    fallbacks += ws.fallbacks;
  }
  return {traversed, fallbacks, unnecessary};
}

template <bool kCountUnnecessary>
UpdateEngine::TraceCounters UpdateEngine::traceRays(const map::OccupancyMap& map, const Vec3f& origin,
                                                    const std::vector<SuperRay>& rays, bool counting, bool backward,
                                                    bool region) {
  if (counting) {
    if (!backward) return traceRaysImpl<kCountUnnecessary, true, false, false>(map, origin, rays);
    return region ? traceRaysImpl<kCountUnnecessary, true, true, true>(map, origin, rays)
                  : traceRaysImpl<kCountUnnecessary, true, true, false>(map, origin, rays);
  }
  if (!backward) return traceRaysImpl<kCountUnnecessary, false, false, false>(map, origin, rays);
  return region ? traceRaysImpl<kCountUnnecessary, false, true, true>(map, origin, rays)
                : traceRaysImpl<kCountUnnecessary, false, true, false>(map, origin, rays);
}

namespace {
using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }
}  // namespace

std::optional<UpdateStats> UpdateEngine::insert(map::OccupancyMap& map, const std::vector<Vec3f>& points,
                                                const Vec3f& origin) {
  const auto& conv = map.converter();
  UpdateStats st;
  st.points = points.size();
  VoxelKey origin_key;
  if (!origin.allFinite() || !conv.toKey(origin, origin_key)) return std::nullopt;

  const auto t0 = Clock::now();
  // Ray ends after the range limit, and whether they mark an occupied endpoint. Points that are not finite
  // or whose end leaves the key range are dropped, as OctoMap drops them.
  std::vector<Vec3f> ends;
  std::vector<Vec3f> cut_ends;  // rays cut at max range: free only
  ends.reserve(points.size());
  VoxelKey lo = origin_key, hi = origin_key;
  auto grow = [&](const VoxelKey& k) {
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], k[a]);
      hi[a] = std::max(hi[a], k[a]);
    }
  };
  for (const Vec3f& p : points) {
    VoxelKey k;
    if (!p.allFinite()) {
      ++st.rejected;
      continue;
    }
    const geometry::ClippedRay c = geometry::clipRay(origin, p, options_.max_range);
    if (!conv.toKey(c.end, k)) {
      ++st.rejected;
      continue;
    }
    grow(k);
    (c.hit ? ends : cut_ends).push_back(c.end);
  }
  // Rounding can let OctoMap's walk step one cell past the endpoint's box; pad it.
  for (int a = 0; a < 3; ++a) {
    lo[a] = static_cast<geometry::KeyCoord>(std::max(0, lo[a] - 2));
    hi[a] = static_cast<geometry::KeyCoord>(std::min(0xFFFF, hi[a] + 2));
  }
  evidence_.reset(lo, hi);
  st.prepare_ms = msSince(t0);
  const auto tg = Clock::now();

  const bool use_super = options_.method == UpdateMethod::kSuperRays || options_.method == UpdateMethod::kSuperRaysCulling;
  const bool use_culling =
      options_.method == UpdateMethod::kCullingRegion || options_.method == UpdateMethod::kSuperRaysCulling;
  std::vector<SuperRay> rays;
  if (use_super) {
    SuperRayStats sst;
    rays = SuperRayGenerator(options_.super_rays).generate(conv, origin, ends, &sst);
    st.super_rays = sst.super_rays;
    st.grouped_points = sst.grouped_points;
  } else {
    rays.reserve(ends.size());
    for (const Vec3f& e : ends) rays.push_back({e, 1});
  }
  for (const Vec3f& e : cut_ends) rays.push_back({e, 1});
  st.rays = rays.size();
  if (use_culling) st.region_cells = CullingRegion::build(map, origin_key, evidence_).cells;
  st.generation_ms = msSince(tg);

  const auto t1 = Clock::now();
  const bool counting = options_.semantics == UpdateSemantics::kCounting;
  const bool region = use_culling && st.region_cells > 0;
  TraceCounters tc;
  if (options_.count_unnecessary) {
    tc = traceRays<true>(map, origin, rays, counting, use_culling, region);
  } else {
    tc = traceRays<false>(map, origin, rays, counting, use_culling, region);
  }
  st.trace_ms = msSince(t1);
  const auto ta = Clock::now();
  map::ScanEvidence& ev = evidence_;
  // Occupied endpoints (after the free pass, as in OctoMap; the semantics decide how they combine).
#pragma omp parallel for schedule(static)
  for (std::size_t i = 0; i < ends.size(); ++i) {
    VoxelKey k;
    conv.toKey(ends[i], k);
    if (counting) {
      ev.addHit(k, 1);
    } else {
      ev.markHit(k);
    }
  }
  // Batch semantics: occupied wins, so a hit cell gets no free update this scan.
  if (!counting) ev.resolveOccupiedWins();
  map.apply(ev);
  st.apply_ms = msSince(ta);
  st.update_ms = st.prepare_ms + msSince(t1);
  st.traversed = tc.traversed;
  st.fallbacks = tc.fallbacks;
  st.unnecessary = tc.unnecessary;
  return st;
}

}  // namespace densemap::update
