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
  if (max_range < 0.0) return {point, true};  // unlimited: no norm needed
  // Same float/double mix as octomath::Vector3::norm(): float sum of squares, double sqrt.
  const float dx = point.x() - origin.x(), dy = point.y() - origin.y(), dz = point.z() - origin.z();
  const float sq = dx * dx + dy * dy + dz * dz;
  const double norm = std::sqrt(static_cast<double>(sq));
  if (norm <= max_range) return {point, true};
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

/// setupRay() with both keys already known (conv.toKey of origin and end): the origin's is the same for a
/// whole scan and the end's is known where rays are grouped by end cell, so callers need not recompute them.
inline void setupRayWithKeys(const KeyConverter& conv, const Vec3f& origin, const VoxelKey& origin_key,
                             const Vec3f& end, const VoxelKey& end_key, RaySetup& r) {
  r.origin_key = origin_key;
  r.end_key = end_key;
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
}

/// As setupRay(), with the origin's key known (`origin_key` = conv.toKey(origin)).
inline bool setupRay(const KeyConverter& conv, const Vec3f& origin, const VoxelKey& origin_key,
                     const Vec3f& end, RaySetup& r) {
  VoxelKey end_key;
  if (!conv.toKey(end, end_key)) return false;
  setupRayWithKeys(conv, origin, origin_key, end, end_key, r);
  return true;
}

/// False when the origin or the endpoint lies outside the key range (OctoMap then skips the ray).
inline bool setupRay(const KeyConverter& conv, const Vec3f& origin, const Vec3f& end, RaySetup& r) {
  VoxelKey origin_key;
  if (!conv.toKey(origin, origin_key)) return false;
  return setupRay(conv, origin, origin_key, end, r);
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
    // OctoMap's choice of the axis with the smallest tMax, with its tie-breaking. (Branches beat a
    // branch-free choice here: speculation overlaps consecutive steps, a select chain serialises them.)
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
  walkForward(
      r, r.end_key, [](const VoxelKey&) { return false; }, visit);
}

/// Where a backward walk starts: per axis, the number of grid crossings between the sensor's cell and the
/// start cell, and the ray parameter of the last of them (-infinity when there is none).
struct BackwardStart {
  int crossings[3] = {0, 0, 0};
  double last[3] = {0, 0, 0};
};

/// Crossing parameters closer than this are a tie that OctoMap's accumulated rounding decides.
inline double tieTolerance(const RaySetup& r) { return 1e-9 * (static_cast<double>(r.length) + 1.0); }

/// Fills `s` for a backward walk from `start`. False when the cells cannot be recomputed backward exactly
/// from there: `start` is not ahead of the sensor's cell along the ray, or (`start_is_end`) a crossing lies
/// so close to the ray's end that rounding could make OctoMap's walk stop a cell early or late.
inline bool backwardStart(const RaySetup& r, const VoxelKey& start, bool start_is_end, BackwardStart& s) {
  const double length = r.length;
  const double tol = tieTolerance(r);
  for (int i = 0; i < 3; ++i) {
    const int diff = static_cast<int>(start[i]) - static_cast<int>(r.origin_key[i]);
    if (r.step[i] == 0) {
      if (diff != 0) return false;
      s.crossings[i] = 0;
      s.last[i] = -std::numeric_limits<double>::infinity();
      continue;
    }
    const int k = diff * r.step[i];
    if (k < 0) return false;
    if (start_is_end) {
      // OctoMap reaches the endpoint cell only if exactly k crossings per axis lie before the ray's end.
      const double next = r.t_max0[i] + static_cast<double>(k) * r.t_delta[i];
      if (!(next > length + tol)) return false;
    }
    s.crossings[i] = k;
    s.last[i] = k > 0 ? r.t_max0[i] + static_cast<double>(k - 1) * r.t_delta[i]
                      : -std::numeric_limits<double>::infinity();
    if (start_is_end && k > 0 && !(s.last[i] < length - tol)) return false;
  }
  return true;
}

/// How a backward walk ended.
enum class WalkEnd {
  kOrigin,    ///< reached the sensor's cell (visited it)
  kRegion,    ///< entered the culling region: the rest of the ray cannot change the map
  kStopped,   ///< `stop(key)` held for the next cell (returned in WalkResult::at, not visited)
  kFallback,  ///< a rounding tie: the rest was walked forward with OctoMap's arithmetic (no stop possible)
};

struct WalkResult {
  WalkEnd end;
  VoxelKey at;  ///< the cell where the walk stopped (kStopped)
};

/// Walks the same cells as walkForward, but backward: from `start` (the endpoint cell when `start_is_end`,
/// else a cell on the ray's path, which is not visited) toward the sensor. It ends on entering a cell in
/// the culling region (Sec. 2.3.5: every cell between there and the sensor is in the region too, so the
/// rest of the ray cannot change the map), or before a cell for which `stop` holds. The crossing order is
/// recomputed from the crossing parameters; where two crossings are so close that OctoMap's accumulated
/// rounding could order them differently, the rest of the ray is walked forward with OctoMap's own
/// arithmetic, so the visited cells are always exactly OctoMap's.
template <class InRegion, class Stop, class Visit>
WalkResult walkBackwardFrom(const RaySetup& r, const VoxelKey& start, bool start_is_end, InRegion&& in_region,
                            Stop&& stop, Visit&& visit) {
  if (start == r.origin_key) return {WalkEnd::kOrigin, start};
  const double tol = tieTolerance(r);
  auto fallback = [&](const VoxelKey& stop_key) {
    walkForward(r, stop_key, in_region, visit);
    return WalkResult{WalkEnd::kFallback, stop_key};
  };
  constexpr double kNone = -std::numeric_limits<double>::infinity();
  BackwardStart bs;
  if (!backwardStart(r, start, start_is_end, bs)) return fallback(start);
  const int* kk = bs.crossings;
  const double* last = bs.last;
  // Scalar state only: indexing arrays by the stepped axis stalls on store forwarding.
  int kx = kk[0], ky = kk[1], kz = kk[2];
  int cx = start[0], cy = start[1], cz = start[2];
  double lx = last[0], ly = last[1], lz = last[2];
  const int sx = r.step[0], sy = r.step[1], sz = r.step[2];
  const double dx = r.t_delta[0], dy = r.t_delta[1], dz = r.t_delta[2];
  auto key = [&] {
    return VoxelKey{{static_cast<KeyCoord>(cx), static_cast<KeyCoord>(cy), static_cast<KeyCoord>(cz)}};
  };
  while ((kx | ky | kz) != 0) {
    // The cell was entered through the axis whose last crossing came latest; a near tie means OctoMap's
    // accumulated rounding decides, so finish with its own forward arithmetic.
    if (lx >= ly && lx >= lz) {
      if (lx - std::max(ly, lz) < tol) return fallback(key());
      cx -= sx;
      lx = --kx > 0 ? lx - dx : kNone;
    } else if (ly >= lz) {
      if (ly - std::max(lx, lz) < tol) return fallback(key());
      cy -= sy;
      ly = --ky > 0 ? ly - dy : kNone;
    } else {
      if (lz - std::max(lx, ly) < tol) return fallback(key());
      cz -= sz;
      lz = --kz > 0 ? lz - dz : kNone;
    }
    const VoxelKey cur = key();
    if (in_region(cur)) return {WalkEnd::kRegion, cur};
    if (stop(cur)) return {WalkEnd::kStopped, cur};
    visit(cur);
  }
  return {WalkEnd::kOrigin, r.origin_key};
}

/// Counters a walker can report to (statistics only).
struct WalkStats {
  std::uint64_t fallbacks = 0;  ///< rays whose backward walk met a rounding tie and finished forward
};

/// The whole ray from its endpoint toward the sensor (see walkBackwardFrom).
template <class InRegion, class Visit>
void walkBackward(const RaySetup& r, InRegion&& in_region, Visit&& visit, WalkStats* stats = nullptr) {
  if (r.origin_key == r.end_key) return;
  const WalkResult res = walkBackwardFrom(
      r, r.end_key, true, in_region, [](const VoxelKey&) { return false; }, visit);
  if (stats && res.end == WalkEnd::kFallback) ++stats->fallbacks;
}

}  // namespace densemap::geometry
