#include "densemap/server/query_service.h"

#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "densemap/map/map_file.h"
#include "densemap/server/dense_stage.h"

namespace densemap::server {

using geometry::Vec3f;
using geometry::VoxelKey;

namespace {

struct InvalidArgument : std::runtime_error {
  using std::runtime_error::runtime_error;
};

Vec3f vec(const std::array<float, 3>& a) { return {a[0], a[1], a[2]}; }

float probability(float log_odds) { return map::OccupancyParams::probability(log_odds); }

/// The key range a box covers, clamped to the map's key range; throws on an invalid box.
std::pair<VoxelKey, VoxelKey> boxKeys(const geometry::KeyConverter& conv, const msg::QueryRequest& rq) {
  const Vec3f lo = vec(rq.box_min()), hi = vec(rq.box_max());
  if (!lo.allFinite() || !hi.allFinite()) throw InvalidArgument("the box corners must be finite");
  for (int a = 0; a < 3; ++a) {
    if (lo[a] > hi[a]) {
      throw InvalidArgument(
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

/// The request's number of points; throws when they are not packed x y z or too many.
std::size_t pointCount(const msg::QueryRequest& rq, const QueryLimits& limits) {
  const auto& xyz = rq.points();
  if (xyz.size() % 3 != 0) throw InvalidArgument("points must be packed x y z (a multiple of 3 floats)");
  const std::size_t n = xyz.size() / 3;
  if (n > limits.max_points) {
    throw InvalidArgument(fmt::format("{} points is over the limit of {} per query", n, limits.max_points));
  }
  return n;
}

/// The ray's unit direction; throws when the origin, direction or range are not usable.
Vec3f rayDirection(const msg::QueryRequest& rq, const QueryLimits& limits) {
  const Vec3f origin = vec(rq.ray_origin());
  const Vec3f dir = vec(rq.ray_direction());
  if (!origin.allFinite() || !dir.allFinite() || dir.norm() == 0.0f) {
    throw InvalidArgument("the ray needs a finite origin and a finite, non-zero direction");
  }
  if (!(rq.max_range() > 0.0f) || rq.max_range() > limits.max_ray_range) {
    throw InvalidArgument(fmt::format("max_range must be in (0, {}] m", limits.max_ray_range));
  }
  return dir.normalized();
}

}  // namespace

msg::MapStatistics mapStatistics(const map::OccupancyMap& map, std::uint64_t version) {
  msg::MapStatistics s;
  s.backend(map.backendName());
  s.resolution(map.resolution());
  s.map_version(version);
  s.memory_bytes(map.memoryBytes());
  std::uint64_t known = 0, occupied = 0;
  Vec3f lo = Vec3f::Constant(std::numeric_limits<float>::max()), hi = -lo;
  const float threshold = map::OccupancyParams::logOdds(map.params().occupied_threshold);
  map.forEachCell([&](const VoxelKey& k, float v) {
    ++known;
    if (v >= threshold) ++occupied;
    const Vec3f c = map.converter().toCoord(k);
    lo = lo.cwiseMin(c);
    hi = hi.cwiseMax(c);
  });
  s.known_cells(known);
  s.occupied_cells(occupied);
  if (known == 0) lo = hi = Vec3f::Zero();
  s.bounds_min({lo.x(), lo.y(), lo.z()});
  s.bounds_max({hi.x(), hi.y(), hi.z()});
  return s;
}

msg::QueryReply QueryService::answer(const msg::QueryRequest& rq) {
  const auto t0 = std::chrono::steady_clock::now();
  msg::QueryReply rp;
  rp.client_id(rq.client_id());
  rp.request_id(rq.request_id());
  rp.kind(rq.kind());
  rp.status(msg::STATUS_OK);
  try {
    const unsigned layer = static_cast<unsigned>(rq.layer());
    const bool per_cell_kind =
        rq.kind() == msg::QUERY_POINTS || rq.kind() == msg::QUERY_BOX || rq.kind() == msg::QUERY_RAY;
    if (layer > msg::LAYER_FUSED) {
      rp.status(msg::STATUS_INVALID_ARGUMENT);
      rp.message(fmt::format("unknown layer {} (occupancy 0, dense 1, fused 2)", layer));
    } else if (rq.layer() != msg::LAYER_OCCUPANCY && dense_ == nullptr) {
      rp.status(msg::STATUS_LAYER_UNAVAILABLE);
      rp.message("this server builds no dense layer; start it with --dense-layer akimap (or bgk)");
    } else if (rq.layer() != msg::LAYER_OCCUPANCY && per_cell_kind) {
      denseQuery(rq, rp);
    } else {
      switch (rq.kind()) {
        case msg::QUERY_POINTS:
          points(rq, rp);
          break;
        case msg::QUERY_BOX:
          box(rq, rp);
          break;
        case msg::QUERY_RAY:
          ray(rq, rp);
          break;
        case msg::QUERY_STATS:
          stats(rp);
          break;
        case msg::QUERY_SAVE:
          save(rq, rp);
          break;
        case msg::QUERY_CLEAR_BOX:
          clearBox(rq, rp);
          break;
        case msg::QUERY_RESET:
          reset(rp);
          break;
        default:
          rp.status(msg::STATUS_UNKNOWN_KIND);
          rp.message(fmt::format("unknown query kind {}; this server knows kinds 0..{}",
                                 static_cast<unsigned>(rq.kind()), static_cast<unsigned>(msg::QUERY_RESET)));
      }
    }
  } catch (const InvalidArgument& e) {
    rp.status(msg::STATUS_INVALID_ARGUMENT);
    rp.message(e.what());
  } catch (const std::exception& e) {
    rp.status(msg::STATUS_FAILED);
    rp.message(e.what());
  }
  latency_.add(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  if (rp.status() == msg::STATUS_OK) {
    ++answered_;
  } else {
    ++failed_;
    spdlog::warn("query {}#{} failed: {}", rq.client_id(), rq.request_id(), rp.message());
  }
  return rp;
}

void QueryService::denseQuery(const msg::QueryRequest& rq, msg::QueryReply& rp) {
  const bool fused = rq.layer() == msg::LAYER_FUSED;
  store_.read([&](const map::OccupancyMap& m, std::uint64_t version) {
    rp.map_version(version);
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
      if (rq.kind() == msg::QUERY_POINTS) {
        const auto& xyz = rq.points();
        const std::size_t n = pointCount(rq, limits_);
        rp.probabilities().resize(n);
        rp.states().resize(n);
        for (std::size_t i = 0; i < n; ++i) {
          const auto p = probabilityAt(Vec3f(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]));
          rp.probabilities()[i] = p.value_or(0.5f);
          rp.states()[i] = !p ? msg::CELL_UNKNOWN : *p >= 0.5f ? msg::CELL_OCCUPIED : msg::CELL_FREE;
        }
      } else if (rq.kind() == msg::QUERY_BOX) {
        const geometry::KeyConverter conv(d.options().resolution);
        const auto [lo, hi] = boxKeys(conv, rq);
        double cells = 1;
        for (int a = 0; a < 3; ++a) cells *= static_cast<double>(hi[a] - lo[a] + 1);
        if (cells > 16e6) {
          throw InvalidArgument(
              fmt::format("the box holds {:.0f} dense cells; at most 16 million per query", cells));
        }
        const std::uint32_t limit = rq.limit() == 0 ? limits_.default_box_limit : rq.limit();
        VoxelKey k;
        for (int x = lo[0]; x <= hi[0]; ++x)
          for (int y = lo[1]; y <= hi[1]; ++y)
            for (int z = lo[2]; z <= hi[2]; ++z) {
              k = VoxelKey{{static_cast<geometry::KeyCoord>(x), static_cast<geometry::KeyCoord>(y),
                            static_cast<geometry::KeyCoord>(z)}};
              const Vec3f c = conv.toCoord(k);
              const auto p = probabilityAt(c);
              if (!p || *p < 0.5f) continue;
              if (rp.cells().size() / 3 >= limit) {
                rp.truncated(true);
                continue;
              }
              rp.cells().insert(rp.cells().end(), {c.x(), c.y(), c.z()});
            }
      } else {  // QUERY_RAY: march at half the finer resolution
        const Vec3f origin = vec(rq.ray_origin());
        const Vec3f dir = rayDirection(rq, limits_);
        const float step = static_cast<float>(0.5 * res);
        for (float t = 0.0f; t <= rq.max_range(); t += step) {
          const Vec3f q = origin + dir * t;
          const auto p = probabilityAt(q);
          if (p && *p >= 0.5f) {
            rp.hit(true);
            rp.hit_point({q.x(), q.y(), q.z()});
            rp.message(fmt::format("hit at {:.2f} m", t));
            return 0;
          }
          if (!p && !rq.ignore_unknown()) {
            rp.message(fmt::format("reached an unknown cell at {:.2f} m", t));
            return 0;
          }
        }
        rp.message("no occupied cell within max_range");
      }
      return 0;
    });
  });
}

void QueryService::points(const msg::QueryRequest& rq, msg::QueryReply& rp) {
  const auto& xyz = rq.points();
  const std::size_t n = pointCount(rq, limits_);
  std::vector<float> probs(n), log_odds(n);
  std::vector<uint8_t> states(n), valid(n);
  std::vector<VoxelKey> keys(n);
  store_.read([&](const map::OccupancyMap& m, std::uint64_t version) {
    for (std::size_t i = 0; i < n; ++i) {
      const Vec3f p(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);
      valid[i] = p.allFinite() && m.converter().toKey(p, keys[i]);
      if (!valid[i]) keys[i] = VoxelKey{{0, 0, 0}};  // looked up like the others, answered unknown below
    }
    m.logOddsMany(keys, log_odds);  // one batch: the lookups' cache misses overlap
    const float threshold = map::OccupancyParams::logOdds(m.params().occupied_threshold);
    for (std::size_t i = 0; i < n; ++i) {
      const float v = log_odds[i];
      if (!valid[i] || std::isnan(v)) {
        probs[i] = 0.5f;
        states[i] = msg::CELL_UNKNOWN;
      } else {
        probs[i] = probability(v);
        states[i] = v >= threshold ? msg::CELL_OCCUPIED : msg::CELL_FREE;
      }
    }
    rp.map_version(version);
    return 0;
  });
  rp.probabilities(std::move(probs));
  rp.states(std::move(states));
}

void QueryService::box(const msg::QueryRequest& rq, msg::QueryReply& rp) {
  std::uint32_t limit = rq.limit() == 0 ? limits_.default_box_limit : rq.limit();
  if (limit > limits_.max_box_limit) {
    throw InvalidArgument(
        fmt::format("limit {} is above the server's maximum of {}", limit, limits_.max_box_limit));
  }
  std::vector<float> cells;
  bool truncated = false;
  store_.read([&](const map::OccupancyMap& m, std::uint64_t version) {
    const auto [lo, hi] = boxKeys(m.converter(), rq);
    const float threshold = map::OccupancyParams::logOdds(m.params().occupied_threshold);
    m.forEachCellInBox(lo, hi, [&](const VoxelKey& k, float v) {
      if (v < threshold) return;
      if (cells.size() / 3 >= limit) {
        truncated = true;
        return;
      }
      const Vec3f c = m.converter().toCoord(k);
      cells.insert(cells.end(), {c.x(), c.y(), c.z()});
    });
    rp.map_version(version);
    return 0;
  });
  rp.cells(std::move(cells));
  rp.truncated(truncated);
}

void QueryService::ray(const msg::QueryRequest& rq, msg::QueryReply& rp) {
  const Vec3f origin = vec(rq.ray_origin());
  const Vec3f dir = rayDirection(rq, limits_);
  store_.read([&](const map::OccupancyMap& m, std::uint64_t version) {
    rp.map_version(version);
    const auto& conv = m.converter();
    VoxelKey key;
    if (!conv.toKey(origin, key)) throw InvalidArgument("the ray origin lies outside the map's key range");
    const float threshold = map::OccupancyParams::logOdds(m.params().occupied_threshold);
    // Amanatides-Woo stepping through the cells the ray crosses, up to max_range.
    const double res = conv.resolution();
    int step[3];
    double t_max[3], t_delta[3];
    for (int a = 0; a < 3; ++a) {
      step[a] = dir[a] > 0 ? 1 : (dir[a] < 0 ? -1 : 0);
      if (step[a] == 0) {
        t_max[a] = t_delta[a] = std::numeric_limits<double>::infinity();
        continue;
      }
      const double border = conv.lowerBound(key[a]) + (step[a] > 0 ? res : 0.0);
      t_max[a] = (border - origin[a]) / dir[a];
      t_delta[a] = res / std::abs(dir[a]);
    }
    double t = 0.0;
    while (t <= rq.max_range()) {
      const std::optional<float> v = m.logOdds(key);
      if (v && *v >= threshold) {
        const Vec3f c = conv.toCoord(key);
        rp.hit(true);
        rp.hit_point({c.x(), c.y(), c.z()});
        rp.message(fmt::format("hit at {:.2f} m", t));
        return 0;
      }
      if (!v && !rq.ignore_unknown()) {
        rp.message(fmt::format("reached an unknown cell at {:.2f} m", t));
        return 0;
      }
      const int a = t_max[0] < t_max[1] ? (t_max[0] < t_max[2] ? 0 : 2) : (t_max[1] < t_max[2] ? 1 : 2);
      t = t_max[a];
      t_max[a] += t_delta[a];
      const int next = static_cast<int>(key[a]) + step[a];
      if (next < 0 || next >= 2 * geometry::kKeyCenter) break;
      key[a] = static_cast<geometry::KeyCoord>(next);
    }
    rp.message("no occupied cell within max_range");
    return 0;
  });
}

void QueryService::stats(msg::QueryReply& rp) {
  store_.read([&](const map::OccupancyMap& m, std::uint64_t version) {
    rp.stats(mapStatistics(m, version));
    rp.map_version(version);
    return 0;
  });
}

void QueryService::save(const msg::QueryRequest& rq, msg::QueryReply& rp) {
  if (rq.path().empty()) throw InvalidArgument("save needs a server-side path ending in .bt or .ot");
  if (!rq.path().ends_with(".bt") && !rq.path().ends_with(".ot")) {
    throw InvalidArgument("cannot save '" + rq.path() + "': the file name must end in .bt or .ot");
  }
  store_.read([&](const map::OccupancyMap& m, std::uint64_t version) {
    map::saveMap(m, rq.path());
    rp.stats(mapStatistics(m, version));
    rp.map_version(version);
    return 0;
  });
  rp.message("saved " + rq.path());
  spdlog::info("saved the map to {} (version {})", rq.path(), rp.map_version());
}

void QueryService::clearBox(const msg::QueryRequest& rq, msg::QueryReply& rp) {
  // Validate here (a clear error now), run on the map's writer thread (between scans).
  store_.read([&](const map::OccupancyMap& m, std::uint64_t) {
    boxKeys(m.converter(), rq);
    return 0;
  });
  const std::uint64_t changed = store_
                                    .post([rq](map::OccupancyMap& m) -> std::uint64_t {
                                      const auto [lo, hi] = boxKeys(m.converter(), rq);
                                      return m.eraseBox(lo, hi);
                                    })
                                    .get();
  rp.cells_changed(changed);
  rp.map_version(store_.version());
  rp.message(fmt::format("cleared {} cells", changed));
}

void QueryService::reset(msg::QueryReply& rp) {
  const std::uint64_t changed = store_
                                    .post([](map::OccupancyMap& m) -> std::uint64_t {
                                      const std::uint64_t n = m.knownCells();
                                      m.clear();
                                      return n;
                                    })
                                    .get();
  if (dense_ != nullptr) dense_->clear();
  rp.cells_changed(changed);
  rp.map_version(store_.version());
  rp.message(fmt::format("reset: forgot {} cells", changed));
  spdlog::info("map reset by {} ({} cells forgotten)", "a query", changed);
}

}  // namespace densemap::server
