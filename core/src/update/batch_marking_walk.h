// The hot loops of batch semantics (Sec. 2.3.4: a cell is marked at most once per scan): the walks of
// geometry/ray_traversal.h, specialised by the ray's step signs so that marking a cell costs no table
// lookups. Private to ray_tracer.cpp.
#pragma once

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <limits>

#include "densemap/geometry/ray_traversal.h"
#include "densemap/map/scan_evidence.h"

namespace densemap::update {

/// Where a backward walk stops: nowhere (the whole ray), on entering the culling region, or on entering
/// the in-scan closed region.
enum class StopAt { kNothing, kRegion, kClosed };

/// Marks the free cells of rays in one thread. The cell's Morton index inside its evidence block is stepped
/// incrementally (a masked add or subtract on the stepped axis' interleaved bits), and the block is looked
/// up again only when a step leaves it, one step in 16 per axis. The DDA arithmetic, comparisons and end
/// tests are those of geometry::walkForward / walkBackwardFrom, so the cells are OctoMap's.
class BatchMarkingWalk {
 public:
  /// Where this thread's marks go: the free planes themselves when it walks alone, its own lane of them
  /// (map::ScanEvidence::freeLane, merged after the walks) in a team, or locked operations on the free
  /// planes when the team has more threads than lanes.
  static constexpr int kAlone = -1, kLocked = -2;
  static int laneFor(int thread, int team) {
    if (team <= 1) return kAlone;
    return thread < map::ScanEvidence::kMaxFreeLanes ? thread : kLocked;
  }

  BatchMarkingWalk(map::ScanEvidence& ev, int lane) : ev_(ev), lane_(lane) {}

  /// geometry::walkForward marking every cell; returns the number of cells marked.
  template <int kSx, int kSy, int kSz>
  std::uint64_t forward(const geometry::RaySetup& r) {
    if (r.origin_key == r.end_key) return 0;
    double tx = r.t_max0[0], ty = r.t_max0[1], tz = r.t_max0[2];
    const double dx = r.t_delta[0], dy = r.t_delta[1], dz = r.t_delta[2];
    int kx = r.origin_key[0], ky = r.origin_key[1], kz = r.origin_key[2];
    const int ex = r.end_key[0], ey = r.end_key[1], ez = r.end_key[2];
    const double length = r.length;
    // Every step moves one cell along the ray's step signs, so the end cell can be reached only after
    // exactly its L1 distance in steps: one counter replaces the three-way key test of every step.
    int steps_to_end = std::abs(ex - kx) + std::abs(ey - ky) + std::abs(ez - kz);
    enterBlock(kx, ky, kz);
    unsigned m = static_cast<unsigned>(map::voxelIndexInBlock(r.origin_key));
    mark(m, kx, ky, kz);
    std::uint64_t visits = 1;
    // OctoMap's loop is: step along the axis of least t; stop on the end cell; stop when min(t) > length;
    // mark. The axis the next step chooses holds min(t), so the length test is made there, before the
    // mark of the cell it leaves, and the three-way minimum is not computed twice.
    // kLeave: test and mark the cell being left (every step but the first, whose cell was marked above).
    auto advance = [&]<bool kLeave>() __attribute__((always_inline))->bool {
      auto leave = [&](double t) __attribute__((always_inline)) {
        if constexpr (kLeave) {
          if (t > length) return false;
          mark(m, kx, ky, kz);
          ++visits;
        }
        return true;
      };
      if (tx < ty) {
        if (tx < tz) {
          if (!leave(tx)) return false;
          step<kSx, kMortonX>(kx, m, kx, ky, kz);
          tx += dx;
        } else {
          if (!leave(tz)) return false;
          step<kSz, kMortonZ>(kz, m, kx, ky, kz);
          tz += dz;
        }
      } else if (ty < tz) {
        if (!leave(ty)) return false;
        step<kSy, kMortonY>(ky, m, kx, ky, kz);
        ty += dy;
      } else {
        if (!leave(tz)) return false;
        step<kSz, kMortonZ>(kz, m, kx, ky, kz);
        tz += dz;
      }
      return !(--steps_to_end == 0 && kx == ex && ky == ey && kz == ez);
    };
    if (advance.template operator()<false>()) {
      while (advance.template operator()<true>()) {
      }
    }
    return visits;
  }

  /// geometry::walkBackward from the endpoint toward the sensor, marking every cell until it enters the
  /// region `kStop` names (Sec. 2.3.5). On a rounding tie it calls `fallback(stop_key)`, which must walk
  /// the rest forward with OctoMap's arithmetic (as walkBackwardFrom does), and returns the cells it marked
  /// itself.
  template <int kSx, int kSy, int kSz, StopAt kStop, class Fallback>
  std::uint64_t backward(const geometry::RaySetup& r, Fallback&& fallback) {
    if (r.origin_key == r.end_key) return 0;
    const double tol = geometry::tieTolerance(r);
    constexpr double kNone = -std::numeric_limits<double>::infinity();
    geometry::BackwardStart bs;
    if (!geometry::backwardStart(r, r.end_key, true, bs)) {
      fallback(r.end_key);
      return 0;
    }
    const int* kk = bs.crossings;
    const double* last = bs.last;
    int nx = kk[0], ny = kk[1], nz = kk[2];
    int kx = r.end_key[0], ky = r.end_key[1], kz = r.end_key[2];
    double lx = last[0], ly = last[1], lz = last[2];
    const double dx = r.t_delta[0], dy = r.t_delta[1], dz = r.t_delta[2];
    enterBlock(kx, ky, kz);
    unsigned m = static_cast<unsigned>(map::voxelIndexInBlock(r.end_key));
    std::uint64_t visits = 0;
    while ((nx | ny | nz) != 0) {
      // The cell was entered through the axis whose last crossing came latest; a near tie means OctoMap's
      // accumulated rounding decides, so the rest is walked forward with its own arithmetic.
      if (lx >= ly && lx >= lz) {
        if (lx - std::max(ly, lz) < tol) {
          fallback(key(kx, ky, kz));
          return visits;
        }
        step<-kSx, kMortonX>(kx, m, kx, ky, kz);
        lx = --nx > 0 ? lx - dx : kNone;
      } else if (ly >= lz) {
        if (ly - std::max(lx, lz) < tol) {
          fallback(key(kx, ky, kz));
          return visits;
        }
        step<-kSy, kMortonY>(ky, m, kx, ky, kz);
        ly = --ny > 0 ? ly - dy : kNone;
      } else {
        if (lz - std::max(lx, ly) < tol) {
          fallback(key(kx, ky, kz));
          return visits;
        }
        step<-kSz, kMortonZ>(kz, m, kx, ky, kz);
        lz = --nz > 0 ? lz - dz : kNone;
      }
      if constexpr (kStop != StopAt::kNothing) {
        constexpr map::BitPlane map::EvidenceBlock::*kPlane =
            kStop == StopAt::kRegion ? &map::EvidenceBlock::region : &map::EvidenceBlock::closed;
        if (block_ != nullptr && (block_->*kPlane).testAtomic(static_cast<int>(m))) return visits;
      }
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
    // is exactly when the block changes. (An axis with no step is never stepped: the dispatch gives it
    // +1, and its crossing parameter stays at DBL_MAX forward, -infinity backward.)
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
    block_ = ev_.findBlock(key(kx, ky, kz));
    plane_ = block_ != nullptr ? planeOf(*block_) : nullptr;
  }
  [[gnu::always_inline]] map::BitPlane* planeOf(map::EvidenceBlock& b) {
    if (lane_ >= 0) return &ev_.freeLane(lane_, b);
    return lane_ == kAlone ? &b.free : nullptr;
  }
  [[gnu::always_inline]] void mark(unsigned m, int kx, int ky, int kz) {
    if (plane_ != nullptr) [[likely]] {
      plane_->set(static_cast<int>(m));  // no other thread writes this plane during the walks
    } else {
      markSlow(kx, ky, kz);
    }
  }
  /// First mark in a block this scan (allocates it), a cell outside the scan's box (overflow map), or a
  /// thread without a lane.
  [[gnu::noinline, gnu::cold]] void markSlow(int kx, int ky, int kz) {
    const geometry::VoxelKey k = key(kx, ky, kz);
    if (block_ == nullptr && (block_ = ev_.block(k)) != nullptr) plane_ = planeOf(*block_);
    if (plane_ != nullptr) {
      plane_->set(map::voxelIndexInBlock(k));
    } else if (block_ != nullptr) {
      block_->free.setAtomic(map::voxelIndexInBlock(k));
    } else {
      ev_.markFree(k);
    }
  }
  static geometry::VoxelKey key(int kx, int ky, int kz) {
    return geometry::VoxelKey{{static_cast<geometry::KeyCoord>(kx), static_cast<geometry::KeyCoord>(ky),
                               static_cast<geometry::KeyCoord>(kz)}};
  }

  map::ScanEvidence& ev_;
  int lane_;
  map::EvidenceBlock* block_ = nullptr;
  map::BitPlane* plane_ = nullptr;  // where marks in block_ go; null: markSlow decides
};

/// Calls f.template operator()<kSx, kSy, kSz>() with the ray's step signs (an axis with no step gets +1).
template <class F>
decltype(auto) withStepSigns(const geometry::RaySetup& r, F&& f) {
  switch ((r.step[0] < 0 ? 1 : 0) | (r.step[1] < 0 ? 2 : 0) | (r.step[2] < 0 ? 4 : 0)) {
    case 0:
      return f.template operator()<1, 1, 1>();
    case 1:
      return f.template operator()<-1, 1, 1>();
    case 2:
      return f.template operator()<1, -1, 1>();
    case 3:
      return f.template operator()<-1, -1, 1>();
    case 4:
      return f.template operator()<1, 1, -1>();
    case 5:
      return f.template operator()<-1, 1, -1>();
    case 6:
      return f.template operator()<1, -1, -1>();
    default:
      return f.template operator()<-1, -1, -1>();
  }
}

}  // namespace densemap::update
