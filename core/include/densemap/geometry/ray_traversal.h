// 3D DDA ray traversal (Amanatides & Woo) with the cell sequence of OctoMap 1.9.7's
// OcTreeBaseImpl::computeRayKeys, walked forward (the baseline) or backward from the endpoint toward the
// sensor (the culling-region update of Sec. 2.3.5, which stops on entering the region).
#pragma once

#include <cmath>
#include <limits>

#include "densemap/geometry/voxel_key.h"

namespace densemap::geometry {

/// Where a measured point's ray ends, after applying a maximum range as OctoMap's insertPointCloud does:
/// a point beyond the range gives a free ray cut at the range and no occupied endpoint.
struct ClippedRay {
  Vec3f end;
  bool hit = true;  ///< false when the ray was cut at the maximum range
};

inline ClippedRay clipRay(const Vec3f& origin, const Vec3f& point, double max_range) {
  // Same float/double mix as octomath::Vector3::norm(): float sum of squares, double sqrt.
  const float dx = point.x() - origin.x(), dy = point.y() - origin.y(), dz = point.z() - origin.z();
  const float sq = dx * dx + dy * dy + dz * dz;
  const double norm = std::sqrt(static_cast<double>(sq));
  if (max_range < 0.0 || norm <= max_range) return {point, true};
  const float len = static_cast<float>(norm);
  const float r = static_cast<float>(max_range);
  const Vec3f dir(dx / len, dy / len, dz / len);
  return {Vec3f(origin.x() + dir.x() * r, origin.y() + dir.y() * r, origin.z() + dir.z() * r), false};
}

/// The initial state of OctoMap's DDA for one ray, computed with OctoMap's exact arithmetic.
struct RaySetup {
  VoxelKey origin_key;
  VoxelKey end_key;
  int step[3] = {0, 0, 0};
  double t_max0[3] = {0, 0, 0};   ///< ray parameter of the first grid-plane crossing per axis
  double t_delta[3] = {0, 0, 0};  ///< parameter distance between crossings per axis
  float length = 0.0f;
};

/// False when the origin or the endpoint lies outside the key range (OctoMap then skips the ray).
inline bool setupRay(const KeyConverter& conv, const Vec3f& origin, const Vec3f& end, RaySetup& r) {
  if (!conv.toKey(origin, r.origin_key) || !conv.toKey(end, r.end_key)) return false;
  float d[3] = {end.x() - origin.x(), end.y() - origin.y(), end.z() - origin.z()};
  const float sq = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
  r.length = static_cast<float>(std::sqrt(static_cast<double>(sq)));
  const double half = conv.resolution() * 0.5;
  for (int i = 0; i < 3; ++i) {
    d[i] /= r.length;
    if (d[i] > 0.0f) {
      r.step[i] = 1;
    } else if (d[i] < 0.0f) {
      r.step[i] = -1;
    } else {
      r.step[i] = 0;
    }
    if (r.step[i] != 0) {
      double border = conv.toCoord(r.origin_key[i]);
      border += static_cast<float>(r.step[i] * half);
      r.t_max0[i] = (border - static_cast<double>(origin[i])) / static_cast<double>(d[i]);
      r.t_delta[i] = conv.resolution() / std::fabs(static_cast<double>(d[i]));
    } else {
      r.t_max0[i] = std::numeric_limits<double>::max();
      r.t_delta[i] = std::numeric_limits<double>::max();
    }
  }
  return true;
}

/// Forward walk identical to OctoMap's computeRayKeys: visits the origin cell and every cell up to, not
/// including, the endpoint cell (or the cell where accumulated rounding makes OctoMap stop). Cells for
/// which `skip(key)` holds are not visited, and the walk ends before `stop_key`. The state is kept in scalar
/// registers (indexing a key array by the stepped axis causes store-forwarding stalls).
template <class Skip, class Visit>
void walkForward(const RaySetup& r, const VoxelKey& stop_key, Skip&& skip, Visit&& visit) {
  if (r.origin_key == r.end_key || r.origin_key == stop_key) return;
  if (!skip(r.origin_key)) visit(r.origin_key);
  double tx = r.t_max0[0], ty = r.t_max0[1], tz = r.t_max0[2];
  const double dx = r.t_delta[0], dy = r.t_delta[1], dz = r.t_delta[2];
  const int sx = r.step[0], sy = r.step[1], sz = r.step[2];
  int kx = r.origin_key[0], ky = r.origin_key[1], kz = r.origin_key[2];
  const int ex = r.end_key[0], ey = r.end_key[1], ez = r.end_key[2];
  const int qx = stop_key[0], qy = stop_key[1], qz = stop_key[2];
  const double length = r.length;
  while (true) {
    // OctoMap's choice of the axis with the smallest tMax, with its tie-breaking.
    if (tx < ty) {
      if (tx < tz) {
        kx += sx;
        tx += dx;
      } else {
        kz += sz;
        tz += dz;
      }
    } else if (ty < tz) {
      ky += sy;
      ty += dy;
    } else {
      kz += sz;
      tz += dz;
    }
    if ((kx == ex && ky == ey && kz == ez) || (kx == qx && ky == qy && kz == qz)) return;
    if (std::min(std::min(tx, ty), tz) > length) return;
    const VoxelKey cur{{static_cast<KeyCoord>(kx), static_cast<KeyCoord>(ky), static_cast<KeyCoord>(kz)}};
    if (!skip(cur)) visit(cur);
  }
}

template <class Visit>
void walkForward(const RaySetup& r, Visit&& visit) {
  walkForward(r, r.end_key, [](const VoxelKey&) { return false; }, visit);
}

/// Counters a walker can report to (statistics only).
struct WalkStats {
  std::uint64_t fallbacks = 0;  ///< rays whose backward walk met a rounding tie and finished forward
};

/// Walks the same cells as walkForward, but from the endpoint toward the sensor, and stops as soon as a
/// cell satisfies `in_region` (Sec. 2.3.5: every cell between there and the sensor is in the culling
/// region too, so the rest of the ray cannot change the map). The crossing order is recomputed from the
/// crossing parameters; where two crossings are so close that OctoMap's accumulated rounding could order
/// them differently, the remaining part of the ray is walked forward with OctoMap's own arithmetic, so the
/// visited cells are always exactly OctoMap's. Returns the number of visited cells.
template <class InRegion, class Visit>
std::uint32_t walkBackward(const RaySetup& r, InRegion&& in_region, Visit&& visit, WalkStats* stats = nullptr) {
  if (r.origin_key == r.end_key) return 0;
  const double length = r.length;
  const double tol = 1e-9 * (length + 1.0);
  std::uint32_t visited = 0;
  auto fallback = [&](const VoxelKey& stop_key) {
    if (stats) ++stats->fallbacks;
    walkForward(r, stop_key, in_region, [&](const VoxelKey& key) {
      ++visited;
      visit(key);
    });
    return visited;
  };
  int k[3];
  double last[3];
  for (int i = 0; i < 3; ++i) {
    const int diff = static_cast<int>(r.end_key[i]) - static_cast<int>(r.origin_key[i]);
    if (r.step[i] == 0) {
      if (diff != 0) return fallback(r.end_key);
      k[i] = 0;
      last[i] = -std::numeric_limits<double>::infinity();
      continue;
    }
    k[i] = diff * r.step[i];
    if (k[i] < 0) return fallback(r.end_key);
    // OctoMap reaches the endpoint cell only if exactly k[i] crossings per axis lie before the ray's end.
    const double next = r.t_max0[i] + static_cast<double>(k[i]) * r.t_delta[i];
    if (!(next > length + tol)) return fallback(r.end_key);
    if (k[i] > 0) {
      last[i] = r.t_max0[i] + static_cast<double>(k[i] - 1) * r.t_delta[i];
      if (!(last[i] < length - tol)) return fallback(r.end_key);
    } else {
      last[i] = -std::numeric_limits<double>::infinity();
    }
  }
  int kk[3] = {k[0], k[1], k[2]};
  int key[3] = {r.end_key[0], r.end_key[1], r.end_key[2]};
  double l0 = last[0], l1 = last[1], l2 = last[2];
  constexpr double kNone = -std::numeric_limits<double>::infinity();
  auto current = [&] {
    return VoxelKey{{static_cast<KeyCoord>(key[0]), static_cast<KeyCoord>(key[1]), static_cast<KeyCoord>(key[2])}};
  };
  while (kk[0] + kk[1] + kk[2] > 0) {
    // The cell was entered through the axis whose last crossing came latest.
    int a;
    double second;
    if (l0 >= l1) {
      if (l0 >= l2) {
        a = 0;
        second = std::max(l1, l2);
      } else {
        a = 2;
        second = l0;
      }
    } else if (l1 >= l2) {
      a = 1;
      second = std::max(l0, l2);
    } else {
      a = 2;
      second = l1;
    }
    const double la = a == 0 ? l0 : (a == 1 ? l1 : l2);
    if (la - second < tol) return fallback(current());
    const int ka = --kk[a];
    key[a] -= r.step[a];
    const double nl = ka > 0 ? r.t_max0[a] + static_cast<double>(ka - 1) * r.t_delta[a] : kNone;
    if (a == 0) {
      l0 = nl;
    } else if (a == 1) {
      l1 = nl;
    } else {
      l2 = nl;
    }
    const VoxelKey cur = current();
    if (in_region(cur)) return visited;
    ++visited;
    visit(cur);
  }
  return visited;
}

}  // namespace densemap::geometry
