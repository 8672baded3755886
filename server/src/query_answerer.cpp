#include "densemap/server/query_answerer.h"

#include "densemap/map/grid_map.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "densemap/server/box_keys.h"
#include "densemap/server/request_error.h"

namespace densemap::server {

using geometry::VoxelKey;

namespace {

RequestError invalid(const std::string& why) { return RequestError(Status::kInvalidArgument, why); }

float probability(float log_odds) { return map::OccupancyParams::probability(log_odds); }

void checkPointCount(std::size_t n, const QueryLimits& limits) {
  if (n > limits.max_points)
    throw invalid(fmt::format("{} points is over the limit of {} per query", n, limits.max_points));
}

/// The ray's unit direction; throws when the origin, direction or range are not usable.
Vec3f rayDirection(const RayQuery& q, const QueryLimits& limits) {
  if (!q.origin.allFinite() || !q.direction.allFinite() || q.direction.norm() == 0.0f) {
    throw invalid("the ray needs a finite origin and a finite, non-zero direction");
  }
  if (!(q.max_range > 0.0f) || q.max_range > limits.max_ray_range) {
    throw invalid(fmt::format("max_range must be in (0, {}] m", limits.max_ray_range));
  }
  return q.direction.normalized();
}

Layer layerOf(const Query& q) {
  return std::visit(
      [](const auto& x) {
        if constexpr (requires { x.layer; }) {
          return x.layer;
        } else {
          return Layer::kOccupancy;
        }
      },
      q);
}

}  // namespace

std::pair<VoxelKey, VoxelKey> boxKeys(const geometry::KeyConverter& conv, const Vec3f& lo, const Vec3f& hi) {
  if (!lo.allFinite() || !hi.allFinite()) throw invalid("the box corners must be finite");
  for (int a = 0; a < 3; ++a) {
    if (lo[a] > hi[a]) {
      throw invalid(
          fmt::format("inverted box: box_min[{0}] = {1} is above box_max[{0}] = {2}", a, lo[a], hi[a]));
    }
  }
  const double half = conv.resolution() * geometry::kKeyCenter;
  VoxelKey klo, khi;
  for (int a = 0; a < 3; ++a) {
    // Corners beyond the key range are clamped to it (nothing can be stored beyond).
    const double l = std::clamp<double>(lo[a], -half, half - conv.resolution() * 0.5);
    const double h = std::clamp<double>(hi[a], -half, half - conv.resolution() * 0.5);
    conv.toKey(l, klo[a]);
    conv.toKey(h, khi[a]);
  }
  return {klo, khi};
}

bool answerInline(const Query& q) {
  if (const auto* p = std::get_if<PointsQuery>(&q)) return p->points.size() <= 20'000;
  return std::holds_alternative<RayQuery>(q);
}

MapSummary mapSummary(const map::OccupancyMap& map, std::uint64_t version) {
  MapSummary s;
  s.backend = map.backendName();
  s.resolution = map.resolution();
  s.map_version = version;
  s.memory_bytes = map.memoryBytes();
  Vec3f lo = Vec3f::Constant(std::numeric_limits<float>::max()), hi = -lo;
  const float threshold = map::OccupancyParams::logOdds(map.params().occupied_threshold);
  map.forEachCell([&](const VoxelKey& k, float v) {
    ++s.known_cells;
    if (v >= threshold) ++s.occupied_cells;
    const Vec3f c = map.converter().toCoord(k);
    lo = lo.cwiseMin(c);
    hi = hi.cwiseMax(c);
  });
  if (s.known_cells == 0) lo = hi = Vec3f::Zero();
  s.bounds_min = lo;
  s.bounds_max = hi;
  return s;
}

Answer QueryAnswerer::answer(const Query& q) {
  const auto t0 = std::chrono::steady_clock::now();
  Answer a;
  reportingErrors(a, [&] {
    const Layer layer = layerOf(q);
    if (layer != Layer::kOccupancy && dense_ == nullptr) {
      a.status = Status::kLayerUnavailable;
      a.message = "this server builds no dense layer; start it with --dense-layer akimap (or bgk)";
    } else if (layer != Layer::kOccupancy && !std::holds_alternative<StatsQuery>(q)) {
      dense(q, a);
    } else if (const auto* p = std::get_if<PointsQuery>(&q)) {
      points(*p, a);
    } else if (const auto* b = std::get_if<BoxQuery>(&q)) {
      box(*b, a);
    } else if (const auto* r = std::get_if<RayQuery>(&q)) {
      ray(*r, a);
    } else {
      stats(a);
    }
  });
  latency_.add(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  if (a.status == Status::kOk) {
    ++answered_;
  } else {
    ++failed_;
    a.result = std::monostate{};
  }
  return a;
}

void QueryAnswerer::dense(const Query& q, Answer& a) {
  const bool fused = layerOf(q) == Layer::kFused;
  store_.read([&](const map::OccupancyMap& m, std::uint64_t version) {
    a.map_version = version;
    return dense_->read([&](const dense::KernelLayer& d, std::uint64_t) {
      // Fused: the exact map where it observed the cell, the dense layer where it did not.
      auto probabilityAt = [&](const Vec3f& p) -> std::optional<float> {
        if (fused) {
          VoxelKey k;
          if (p.allFinite() && m.converter().toKey(p, k)) {
            if (const auto v = m.logOdds(k)) return probability(*v);
          }
        }
        return d.probability(p);
      };
      const double res = std::min(m.resolution(), d.options().resolution);
      if (const auto* pq = std::get_if<PointsQuery>(&q)) {
        checkPointCount(pq->points.size(), limits_);
        PointsAnswer out;
        out.probabilities.resize(pq->points.size());
        out.states.resize(pq->points.size());
        for (std::size_t i = 0; i < pq->points.size(); ++i) {
          const auto p = probabilityAt(pq->points[i]);
          out.probabilities[i] = p.value_or(0.5f);
          out.states[i] = !p ? CellState::kUnknown : *p >= 0.5f ? CellState::kOccupied : CellState::kFree;
        }
        a.result = std::move(out);
      } else if (const auto* bq = std::get_if<BoxQuery>(&q)) {
        const geometry::KeyConverter conv(d.options().resolution);
        const auto [lo, hi] = boxKeys(conv, bq->min, bq->max);
        double cells = 1;
        for (int ax = 0; ax < 3; ++ax) cells *= static_cast<double>(hi[ax] - lo[ax] + 1);
        if (cells > 16e6) {
          throw invalid(fmt::format("the box holds {:.0f} dense cells; at most 16 million per query", cells));
        }
        const std::uint32_t limit = bq->limit == 0 ? limits_.default_box_limit : bq->limit;
        BoxAnswer out;
        for (int x = lo[0]; x <= hi[0]; ++x)
          for (int y = lo[1]; y <= hi[1]; ++y)
            for (int z = lo[2]; z <= hi[2]; ++z) {
              const VoxelKey k{{static_cast<geometry::KeyCoord>(x), static_cast<geometry::KeyCoord>(y),
                                static_cast<geometry::KeyCoord>(z)}};
              const Vec3f c = conv.toCoord(k);
              const auto p = probabilityAt(c);
              if (!p || *p < 0.5f) continue;
              if (out.cells.size() >= limit) {
                out.truncated = true;
                continue;
              }
              out.cells.push_back(c);
            }
        a.result = std::move(out);
      } else if (const auto* rq = std::get_if<RayQuery>(&q)) {  // march at half the finer resolution
        const Vec3f dir = rayDirection(*rq, limits_);
        const float step = static_cast<float>(0.5 * res);
        RayAnswer out;
        a.message = "no occupied cell within max_range";
        for (float t = 0.0f; t <= rq->max_range; t += step) {
          const Vec3f p3 = rq->origin + dir * t;
          const auto p = probabilityAt(p3);
          if (p && *p >= 0.5f) {
            out.hit = true;
            out.hit_point = p3;
            a.message = fmt::format("hit at {:.2f} m", t);
            break;
          }
          if (!p && !rq->ignore_unknown) {
            a.message = fmt::format("reached an unknown cell at {:.2f} m", t);
            break;
          }
        }
        a.result = out;
      }
      return 0;
    });
  });
}

void QueryAnswerer::points(const PointsQuery& q, Answer& a) {
  const std::size_t n = q.points.size();
  checkPointCount(n, limits_);
  PointsAnswer out;
  out.probabilities.resize(n);
  out.states.resize(n);
  std::vector<float> log_odds(n);
  std::vector<uint8_t> valid(n);
  std::vector<VoxelKey> keys(n);
  store_.read([&](const map::OccupancyMap& m, std::uint64_t version) {
    for (std::size_t i = 0; i < n; ++i) {
      valid[i] = q.points[i].allFinite() && m.converter().toKey(q.points[i], keys[i]);
      if (!valid[i]) keys[i] = VoxelKey{{0, 0, 0}};  // looked up like the others, answered unknown below
    }
    m.logOddsMany(keys, log_odds);  // one batch: the lookups' cache misses overlap
    const float threshold = map::OccupancyParams::logOdds(m.params().occupied_threshold);
    // With a map window, a cell of a block stored out of memory is not unknown: say so.
    const auto* grid = dynamic_cast<const map::GridMap*>(&m);
    const bool some_out = grid != nullptr && grid->outOfMemoryCount() > 0;
    for (std::size_t i = 0; i < n; ++i) {
      const float v = log_odds[i];
      if (!valid[i] || std::isnan(v)) {
        out.probabilities[i] = 0.5f;
        out.states[i] =
            valid[i] && some_out && !grid->inMemory(keys[i]) ? CellState::kNotInMemory : CellState::kUnknown;
      } else {
        out.probabilities[i] = probability(v);
        out.states[i] = v >= threshold ? CellState::kOccupied : CellState::kFree;
      }
    }
    a.map_version = version;
    return 0;
  });
  a.result = std::move(out);
}

void QueryAnswerer::box(const BoxQuery& q, Answer& a) {
  const std::uint32_t limit = q.limit == 0 ? limits_.default_box_limit : q.limit;
  if (limit > limits_.max_box_limit) {
    throw invalid(fmt::format("limit {} is above the server's maximum of {}", limit, limits_.max_box_limit));
  }
  BoxAnswer out;
  store_.read([&](const map::OccupancyMap& m, std::uint64_t version) {
    const auto [lo, hi] = boxKeys(m.converter(), q.min, q.max);
    const float threshold = map::OccupancyParams::logOdds(m.params().occupied_threshold);
    m.forEachCellInBox(lo, hi, [&](const VoxelKey& k, float v) {
      if (v < threshold) return;
      if (out.cells.size() >= limit) {
        out.truncated = true;
        return;
      }
      out.cells.push_back(m.converter().toCoord(k));
    });
    // With a map window, say how much of the box the answer could not read.
    if (const auto* grid = dynamic_cast<const map::GridMap*>(&m); grid && grid->outOfMemoryCount() > 0) {
      out.blocks_not_in_memory = static_cast<std::uint32_t>(std::min<std::size_t>(
          grid->outOfMemoryIn(lo, hi).size(), std::numeric_limits<std::uint32_t>::max()));
      if (out.blocks_not_in_memory > 0)
        a.message =
            fmt::format("{} map blocks in the box are stored out of memory: their cells are not listed",
                        out.blocks_not_in_memory);
    }
    a.map_version = version;
    return 0;
  });
  a.result = std::move(out);
}

void QueryAnswerer::ray(const RayQuery& q, Answer& a) {
  const Vec3f origin = q.origin;
  const Vec3f dir = rayDirection(q, limits_);
  RayAnswer out;
  store_.read([&](const map::OccupancyMap& m, std::uint64_t version) {
    a.map_version = version;
    const auto& conv = m.converter();
    VoxelKey key;
    if (!conv.toKey(origin, key)) throw invalid("the ray origin lies outside the map's key range");
    const float threshold = map::OccupancyParams::logOdds(m.params().occupied_threshold);
    // Amanatides-Woo stepping through the cells the ray crosses, up to max_range.
    const double res = conv.resolution();
    int step[3];
    double t_max[3], t_delta[3];
    for (int ax = 0; ax < 3; ++ax) {
      step[ax] = dir[ax] > 0 ? 1 : (dir[ax] < 0 ? -1 : 0);
      if (step[ax] == 0) {
        t_max[ax] = t_delta[ax] = std::numeric_limits<double>::infinity();
        continue;
      }
      const double border = conv.lowerBound(key[ax]) + (step[ax] > 0 ? res : 0.0);
      t_max[ax] = (border - origin[ax]) / dir[ax];
      t_delta[ax] = res / std::abs(dir[ax]);
    }
    double t = 0.0;
    a.message = "no occupied cell within max_range";
    const auto* grid = dynamic_cast<const map::GridMap*>(&m);
    const bool some_out = grid != nullptr && grid->outOfMemoryCount() > 0;
    while (t <= q.max_range) {
      const std::optional<float> v = m.logOdds(key);
      if (!v && some_out && !grid->inMemory(key)) {
        out.reached_not_in_memory = true;
        out.not_in_memory_at = conv.toCoord(key);
        a.message = fmt::format("reached a map block stored out of memory at {:.2f} m", t);
        return 0;
      }
      if (v && *v >= threshold) {
        out.hit = true;
        out.hit_point = conv.toCoord(key);
        a.message = fmt::format("hit at {:.2f} m", t);
        return 0;
      }
      if (!v && !q.ignore_unknown) {
        a.message = fmt::format("reached an unknown cell at {:.2f} m", t);
        return 0;
      }
      const int ax = t_max[0] < t_max[1] ? (t_max[0] < t_max[2] ? 0 : 2) : (t_max[1] < t_max[2] ? 1 : 2);
      t = t_max[ax];
      t_max[ax] += t_delta[ax];
      const int next = static_cast<int>(key[ax]) + step[ax];
      if (next < 0 || next >= 2 * geometry::kKeyCenter) break;
      key[ax] = static_cast<geometry::KeyCoord>(next);
    }
    return 0;
  });
  a.result = out;
}

void QueryAnswerer::stats(Answer& a) {
  store_.read([&](const map::OccupancyMap& m, std::uint64_t version) {
    a.result = mapSummary(m, version);
    a.map_version = version;
    return 0;
  });
}

}  // namespace densemap::server
