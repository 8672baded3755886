#include "densemap/update/update_engine.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>

#include <omp.h>

#include "densemap/geometry/ray_traversal.h"
#include "densemap/update/culling_region.h"
#include "densemap/update/ray_tracer.h"

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
    case UpdateMethod::kFastest:
      return "fastest";
  }
  return "?";
}

std::optional<UpdateMethod> parseMethod(std::string_view s) {
  for (UpdateMethod m : kAllMethods)
    if (toString(m) == s) return m;
  if (s == "fastest" || s == "default") return UpdateMethod::kFastest;
  if (s == "ours") return UpdateMethod::kSuperRaysCulling;
  return std::nullopt;
}

UpdateEngine::UpdateEngine(UpdateOptions options) : options_(options), chooser_(options.chooser) {}

namespace {
using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}
}  // namespace

std::optional<UpdateStats> UpdateEngine::insert(map::OccupancyMap& map, const std::vector<Vec3f>& points,
                                                const Vec3f& origin, const ApplyWrapper& wrap) {
  const auto& conv = map.converter();
  UpdateStats st;
  st.points = points.size();
  VoxelKey origin_key;
  if (!origin.allFinite() || !conv.toKey(origin, origin_key)) return std::nullopt;

  const bool fastest = options_.method == UpdateMethod::kFastest;
  st.chooser_consulted = fastest && (consult_chooser_ || options_.chooser.min_saving_to_measure <= 0.0);
  const UpdateMethod method =
      !fastest ? options_.method : (st.chooser_consulted ? chooser_.next() : UpdateMethod::kBaseline);
  st.method = method;
  const bool use_super = method == UpdateMethod::kSuperRays || method == UpdateMethod::kSuperRaysCulling;
  const bool use_culling =
      method == UpdateMethod::kCullingRegion || method == UpdateMethod::kSuperRaysCulling;

  const auto t0 = Clock::now();
  // Ray ends after the range limit, and whether they mark an occupied endpoint. Points that are not finite
  // or whose end leaves the key range are dropped, as OctoMap drops them.
  std::vector<Vec3f>& ends = ends_;
  std::vector<Vec3f>& cut_ends = cut_ends_;  // rays cut at max range: free only
  const std::size_t n = points.size();
  // With unlimited range every ray ends at its point, so the points are read in place of a copy.
  const bool unlimited = options_.max_range < 0.0;
  if (!unlimited) clipped_.resize(n);
  kind_.resize(n);
  keys_.resize(n);
  std::uint64_t rejected = 0, cut = 0, walk_cells = 0;
  int lo_x = origin_key[0], lo_y = origin_key[1], lo_z = origin_key[2];
  int hi_x = lo_x, hi_y = lo_y, hi_z = lo_z;
  // Locals, not members: the stores to kind_ (bytes, which may alias anything) would otherwise make the
  // compiler reload every member and vector pointer after each point.
  const Vec3f* pts = points.data();
  std::uint8_t* kind = kind_.data();
  VoxelKey* keys = keys_.data();
  Vec3f* clipped = unlimited ? nullptr : clipped_.data();
  const double max_range = options_.max_range;
  const int ox = origin_key[0], oy = origin_key[1], oz = origin_key[2];
  // Range cut, key range check and bounding box, in parallel; then compacted in input order.
#pragma omp parallel for schedule(static) reduction(+ : rejected, cut, walk_cells) \
    reduction(min : lo_x, lo_y, lo_z) reduction(max : hi_x, hi_y, hi_z)
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3f& p = pts[i];
    VoxelKey k;
    if (!p.allFinite()) {
      ++rejected;
      kind[i] = 0;
      continue;
    }
    const geometry::ClippedRay c = geometry::clipRay(origin, p, max_range);
    if (!conv.toKey(c.end, k)) {
      ++rejected;
      kind[i] = 0;
      continue;
    }
    const int kx = k[0], ky = k[1], kz = k[2];
    lo_x = std::min(lo_x, kx);
    lo_y = std::min(lo_y, ky);
    lo_z = std::min(lo_z, kz);
    hi_x = std::max(hi_x, kx);
    hi_y = std::max(hi_y, ky);
    hi_z = std::max(hi_z, kz);
    // A forward walk takes exactly this many steps (geometry/ray_traversal.h).
    walk_cells += static_cast<std::uint64_t>(std::abs(kx - ox) + std::abs(ky - oy) + std::abs(kz - oz));
    if (clipped != nullptr) clipped[i] = c.end;
    keys[i] = k;  // the endpoint's cell, marked occupied after the walks
    kind[i] = c.hit ? 1 : 2;
    cut += c.hit ? 0 : 1;
  }
  st.rejected = rejected;
  const int blo[3] = {lo_x, lo_y, lo_z}, bhi[3] = {hi_x, hi_y, hi_z};
  VoxelKey lo, hi;
  for (int a = 0; a < 3; ++a) {
    lo[a] = static_cast<geometry::KeyCoord>(blo[a]);
    hi[a] = static_cast<geometry::KeyCoord>(bhi[a]);
  }
  // Sized up front and filled by index (push_back's capacity checks cost more than the copies here). Super
  // rays are made from the endpoints; the other methods walk the rays the compaction writes directly:
  // endpoints first, in input order, then the cut ends.
  const std::size_t ne = n - rejected - cut;
  std::vector<SuperRay>& rays = rays_;
  const std::vector<Vec3f>& at = unlimited ? points : clipped_;
  // Nothing rejected or cut (the common case): every point is a ray of weight 1 ending at it, with its
  // key in keys_, so the methods without super rays walk `at` and keys_ in place, with no compaction.
  const bool in_place = !use_super && rejected == 0 && cut == 0;
  const std::vector<VoxelKey>& end_keys = in_place ? keys_ : end_keys_;
  if (in_place) {
    rays.clear();
  } else if (use_super) {
    ends.resize(ne);
    cut_ends.resize(cut);
  } else {
    rays.resize(ne + cut);
  }
  if (!in_place) {
    end_keys_.resize(ne);
    // Compacted in input order, in parallel: each of `parts` contiguous slices of the points is copied to
    // where the slices before it end (serial, this copy was a quarter of the preparation's time).
    const auto parts = static_cast<std::size_t>(std::max(1, omp_get_max_threads()));
    part_starts_.assign(2 * (parts + 1), 0);  // per slice: first endpoint, first cut end
    auto slice = [&](std::size_t p) { return std::pair{n * p / parts, n * (p + 1) / parts}; };
#pragma omp parallel for schedule(static)
    for (std::size_t p = 0; p < parts; ++p) {
      std::size_t e = 0, c = 0;
      for (auto [i, end] = slice(p); i < end; ++i) {
        e += kind_[i] == 1 ? 1 : 0;
        c += kind_[i] == 2 ? 1 : 0;
      }
      part_starts_[2 * (p + 1)] = e;
      part_starts_[2 * (p + 1) + 1] = c;
    }
    for (std::size_t p = 1; p <= parts; ++p) {
      part_starts_[2 * p] += part_starts_[2 * (p - 1)];
      part_starts_[2 * p + 1] += part_starts_[2 * (p - 1) + 1];
    }
#pragma omp parallel for schedule(static)
    for (std::size_t p = 0; p < parts; ++p) {
      std::size_t e = part_starts_[2 * p], c = part_starts_[2 * p + 1];
      for (auto [i, end] = slice(p); i < end; ++i) {
        if (kind_[i] == 1) {
          end_keys_[e] = keys_[i];
          if (use_super) {
            ends[e] = at[i];
          } else {
            rays[e] = {at[i], 1};
          }
          ++e;
        } else if (kind_[i] == 2) {
          if (use_super) {
            cut_ends[c] = at[i];
          } else {
            rays[ne + c] = {at[i], 1};
          }
          ++c;
        }
      }
    }
  }
  // Rounding can let OctoMap's walk step one cell past the endpoint's box; pad it.
  for (int a = 0; a < 3; ++a) {
    lo[a] = static_cast<geometry::KeyCoord>(std::max(0, lo[a] - 2));
    hi[a] = static_cast<geometry::KeyCoord>(std::min(0xFFFF, hi[a] + 2));
  }
  evidence_.reset(lo, hi, options_.semantics == UpdateSemantics::kCounting);
  st.prepare_ms = msSince(t0);
  const auto tg = Clock::now();

  if (use_super) {
    rays.clear();
    SuperRayStats sst;
    generator_.setOptions(options_.super_rays);
    generator_.generate(conv, origin, ends, rays, &sst, nullptr, &end_keys_);
    st.super_rays = sst.super_rays;
    st.grouped_points = sst.grouped_points;
    for (const Vec3f& e : cut_ends) rays.push_back({e, 1});
  }
  st.rays = in_place ? n : rays.size();
  if (use_culling) st.region_cells = CullingRegion::build(map, origin_key, evidence_).cells;
  st.generation_ms = msSince(tg);

  const auto t1 = Clock::now();
  const bool counting = options_.semantics == UpdateSemantics::kCounting;
  TraceOptions to;
  to.counting = counting;
  to.backward = use_culling;
  to.region = use_culling && st.region_cells > 0;
  to.count_unnecessary = options_.count_unnecessary;
  if (!use_super) to.end_keys = &end_keys;  // ray i is endpoint i for i < ne
  TraceCounters tc;
  auto add = [&](const TraceCounters& c) {
    tc.traversed += c.traversed;
    tc.fallbacks += c.fallbacks;
    tc.unnecessary += c.unnecessary;
    tc.hits_marked = c.hits_marked;
    tc.hit_cells += c.hit_cells;
    tc.shared_walks += c.shared_walks;
  };
  auto trace = [&](const TraceOptions& o) {
    add(in_place ? traceRays(map, evidence_, origin, at, o) : traceRays(map, evidence_, origin, rays, o));
  };
  if (use_culling && !counting && options_.in_scan_closure && st.rays > 64) {
    // Batch semantics: walk a sparse sample first, close the region over what it marked, then let the other
    // rays stop on entering that closed region (marking a cell twice changes nothing).
    to.subset = TraceOptions::Subset::kSample;
    to.sample_every = options_.closure_sample_every;
    trace(to);
    const auto tcl = Clock::now();
    st.closed_cells = CullingRegion::buildClosed(origin_key, evidence_).cells;
    const double closure_ms = msSince(tcl);
    st.generation_ms += closure_ms;
    to.subset = TraceOptions::Subset::kRest;
    to.region = st.closed_cells > 0;
    to.stop_at_closed = true;
    trace(to);
    st.trace_ms -= closure_ms;  // reported under generation
  } else {
    trace(to);
  }
  st.trace_ms += msSince(t1);
  const auto ta = Clock::now();
  map::ScanEvidence& ev = evidence_;
  // Occupied endpoints (after the free pass, as in OctoMap; the semantics decide how they combine).
  // For the default method's rule below: distinct endpoint cells, and the walks of the endpoints whose cell
  // another endpoint already had (what grouping rays by endpoint cell, as super rays do, could save).
  std::uint64_t end_cells = tc.hit_cells, shared_walks = tc.shared_walks;
  // The forward pair walks mark them where they end (TraceCounters::hits_marked); the other walks leave
  // them to this pass.
  if (!tc.hits_marked) {
#pragma omp parallel reduction(+ : end_cells, shared_walks)
    {
      map::EvidenceCursor cursor(ev);
#pragma omp for schedule(static) nowait
      for (std::size_t i = 0; i < end_keys.size(); ++i) {
        const VoxelKey& k = end_keys[i];
        if (counting ? cursor.addHit(k, 1) : cursor.markHit(k)) {
          ++end_cells;
        } else {
          for (int a = 0; a < 3; ++a)
            shared_walks += static_cast<std::uint64_t>(
                std::abs(static_cast<int>(k[a]) - static_cast<int>(origin_key[a])));
        }
      }
    }
  }
  // Batch semantics: occupied wins, so a hit cell gets no free update this scan.
  if (!counting) ev.resolveOccupiedWins();
  // What decides whether the next scan consults the chooser (MethodChooserOptions::min_saving_to_measure).
  if (fastest) {
    st.end_cells = end_cells + ev.overflowHitCells();
    const std::uint64_t walked = n - rejected;
    st.walk_cells_per_ray = walked ? static_cast<double>(walk_cells) / static_cast<double>(walked) : 0.0;
    st.super_ray_saving = ne == 0 ? 0.0 : static_cast<double>(shared_walks) / static_cast<double>(ne);
    consult_chooser_ = st.super_ray_saving >= options_.chooser.min_saving_to_measure;
  }
  double counting_ms = 0.0;
  if (options_.count_cells) {
    const auto tc0 = Clock::now();
    cell_keys_.clear();
    ev.forEachBlock([&](const map::EvidenceBlock& b) {
      b.forEachEvidenceVoxel([&](int i) { cell_keys_.push_back(b.voxelKey(i)); });
    });
    ev.forEachOverflowCell([&](const VoxelKey& k, std::uint32_t, std::uint32_t) { cell_keys_.push_back(k); });
    cell_before_.resize(cell_keys_.size());
    map.logOddsMany(cell_keys_, cell_before_);
    counting_ms = msSince(tc0);
  }
  if (wrap) {
    map.applyPublished(ev, wrap);
  } else {
    map.apply(ev);
  }
  if (options_.count_cells) {
    const auto tc0 = Clock::now();
    std::vector<float> after(cell_keys_.size());
    map.logOddsMany(cell_keys_, after);
    st.updated_cells = cell_keys_.size();
    for (std::size_t i = 0; i < after.size(); ++i) {
      const float a = after[i], b = cell_before_[i];
      st.changed_cells += (a != b && !(std::isnan(a) && std::isnan(b))) ? 1 : 0;
    }
    counting_ms += msSince(tc0);
  }
  st.apply_ms = msSince(ta) - counting_ms;
  st.update_ms = st.prepare_ms + msSince(t1) - counting_ms;
  st.traversed = tc.traversed;
  st.fallbacks = tc.fallbacks;
  st.unnecessary = tc.unnecessary;
  // Applying the evidence is the same work whichever method made it (and may wait for readers' lock), so
  // the choice compares the rest.
  if (st.chooser_consulted) chooser_.record(method, st.totalMs() - st.apply_ms, st.points);
  return st;
}

}  // namespace densemap::update
