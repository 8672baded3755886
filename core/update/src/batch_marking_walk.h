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

  /// What the walks' hit marks found (see TraceCounters::hit_cells and shared_walks).
  struct EndCounts {
    std::uint64_t first_hits = 0, shared_walks = 0;
  };
  const EndCounts& endCounts() const { return ends_; }

  /// geometry::walkForward marking every cell; returns the number of cells marked. `end_hit`: also mark the
  /// endpoint's cell hit (batch semantics: the order of free and hit marks does not matter).
  template <int kSx, int kSy, int kSz>
  std::uint64_t forward(const geometry::RaySetup& r, bool end_hit = false) {
    if (r.origin_key == r.end_key) {
      if (end_hit) countEnd(markHitSlow(r.end_key[0], r.end_key[1], r.end_key[2]), 0);
      return 0;
    }
    ForwardRay s;
    start(s, r);
    markCell(s.target, s.m, s.k);
    if (advance<kSx, kSy, kSz, false>(s)) {
      while (advance<kSx, kSy, kSz, true>(s)) {
      }
    }
    if (end_hit) markEnd(s);
    return s.visits;
  }

  /// Two forward walks at once, for neighbouring rays with the same step signs (`a`'s) and origin cell,
  /// neither ending in it. Such rays cross the same cells for long stretches: a ring's neighbours lie
  /// ~0.2 degrees apart, so where one passes a grid edge on one side and the other on the other, they
  /// differ by one cell and meet again. While they are in the same cell, one walk decides the step (its
  /// branch is the one no predictor learns), the other only checks that it would take the same one, and
  /// the cell is marked once. Each ray's comparisons, end and length tests are its own walk's, so the cells
  /// are exactly those of two forward() calls.
  template <int kSx, int kSy, int kSz>
  std::uint64_t forwardPair(const geometry::RaySetup& ra, const geometry::RaySetup& rb,
                            bool end_hit_a = false, bool end_hit_b = false) {
    ForwardRay a, b;
    start(a, ra);
    start(b, rb);
    markCell(a.target, a.m, a.k);
    bool alive_a = true, alive_b = true, synced = true;
    const int r0 = sharedStep<kSx, kSy, kSz, false>(a, b);  // the first step leaves the origin's cell
    if (r0 != kBothOn) {
      copyPosition(a, b);  // b's position is a's while they are in the same cell
      if (r0 == kDiverged) {
        alive_a = advance<kSx, kSy, kSz, false>(a);
        alive_b = advance<kSx, kSy, kSz, false>(b);
        synced = sameCell(a, b);
      } else {
        alive_a = (r0 & kEndA) == 0;
        alive_b = (r0 & kEndB) == 0;
      }
    }
    while (alive_a && alive_b) {
      if (synced) {
        int r;
        while ((r = sharedStep<kSx, kSy, kSz, true>(a, b)) == kBothOn) {
        }
        copyPosition(a, b);
        if (r != kDiverged) {  // the step was taken; one or both ended
          alive_a = (r & kEndA) == 0;
          alive_b = (r & kEndB) == 0;
          break;
        }
      }
      // Apart: one step each. Both step along the same signs, so they are in the same cell again exactly
      // when their keys are equal.
      do {
        alive_a = advance<kSx, kSy, kSz, true>(a);
        alive_b = advance<kSx, kSy, kSz, true>(b);
      } while (alive_a && alive_b && !sameCell(a, b));
      synced = true;
    }
    if (alive_a) {
      while (advance<kSx, kSy, kSz, true>(a)) {
      }
    }
    if (alive_b) {
      while (advance<kSx, kSy, kSz, true>(b)) {
      }
    }
    if (end_hit_a) markEnd(a);
    if (end_hit_b) markEnd(b);
    return a.visits + b.visits;
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
    int k[3] = {r.end_key[0], r.end_key[1], r.end_key[2]};
    double lx = last[0], ly = last[1], lz = last[2];
    const double dx = r.t_delta[0], dy = r.t_delta[1], dz = r.t_delta[2];
    enterBlock(cur_, k[0], k[1], k[2]);
    unsigned m = static_cast<unsigned>(map::voxelIndexInBlock(r.end_key));
    std::uint64_t visits = 0;
    while ((nx | ny | nz) != 0) {
      // The cell was entered through the axis whose last crossing came latest; a near tie means OctoMap's
      // accumulated rounding decides, so the rest is walked forward with its own arithmetic.
      if (lx >= ly && lx >= lz) {
        if (lx - std::max(ly, lz) < tol) {
          fallback(key(k[0], k[1], k[2]));
          return visits;
        }
        step<-kSx, kMortonX>(cur_, k[0], m, k);
        lx = --nx > 0 ? lx - dx : kNone;
      } else if (ly >= lz) {
        if (ly - std::max(lx, lz) < tol) {
          fallback(key(k[0], k[1], k[2]));
          return visits;
        }
        step<-kSy, kMortonY>(cur_, k[1], m, k);
        ly = --ny > 0 ? ly - dy : kNone;
      } else {
        if (lz - std::max(lx, ly) < tol) {
          fallback(key(k[0], k[1], k[2]));
          return visits;
        }
        step<-kSz, kMortonZ>(cur_, k[2], m, k);
        lz = --nz > 0 ? lz - dz : kNone;
      }
      if constexpr (kStop != StopAt::kNothing) {
        constexpr map::BitPlane map::EvidenceBlock::*kPlane =
            kStop == StopAt::kRegion ? &map::EvidenceBlock::region : &map::EvidenceBlock::closed;
        if (cur_.block != nullptr && (cur_.block->*kPlane).testAtomic(static_cast<int>(m))) return visits;
      }
      markCell(cur_, m, k);
      ++visits;
    }
    return visits;
  }

 private:
  /// Where a walk's marks go: its current block and the plane of it this thread marks (null: markSlow).
  struct Target {
    map::EvidenceBlock* block = nullptr;
    map::BitPlane* plane = nullptr;
  };
  /// One ray of a forward walk: OctoMap's DDA state, its cell and where that cell's mark goes.
  struct ForwardRay {
    double t[3], d[3];
    int k[3], e[3];
    unsigned m;
    int steps_to_end;
    int walk_cells;  // the walk's length in cells had it reached its end: its L1 distance
    double length;
    std::uint64_t visits;
    Target target;
  };

  void start(ForwardRay& s, const geometry::RaySetup& r) {
    for (int i = 0; i < 3; ++i) {
      s.t[i] = r.t_max0[i];
      s.d[i] = r.t_delta[i];
      s.k[i] = r.origin_key[i];
      s.e[i] = r.end_key[i];
    }
    s.length = r.length;
    // Every step moves one cell along the ray's step signs, so the end cell can be reached only after
    // exactly its L1 distance in steps: one counter replaces the three-way key test of every step.
    s.steps_to_end = std::abs(s.e[0] - s.k[0]) + std::abs(s.e[1] - s.k[1]) + std::abs(s.e[2] - s.k[2]);
    s.walk_cells = s.steps_to_end;
    enterBlock(s.target, s.k[0], s.k[1], s.k[2]);
    s.m = static_cast<unsigned>(map::voxelIndexInBlock(r.origin_key));
    s.visits = 1;  // the origin's cell, marked by the caller
  }
  static bool sameCell(const ForwardRay& a, const ForwardRay& b) {
    return a.k[0] == b.k[0] && a.k[1] == b.k[1] && a.k[2] == b.k[2];
  }
  static void copyPosition(const ForwardRay& from, ForwardRay& to) {
    for (int i = 0; i < 3; ++i) to.k[i] = from.k[i];
    to.m = from.m;
    to.target = from.target;
  }

  /// OctoMap's step chooses the axis of least t, ties going to z, then y, then x (rank z 0, y 1, x 2).
  static constexpr int kRank[3] = {2, 1, 0};
  template <int kP, int kQ>
  [[gnu::always_inline]] static bool before(double tp, double tq) {
    if constexpr (kRank[kP] < kRank[kQ]) return tp <= tq;
    return tp < tq;
  }
  /// go.template operator()<axis>() for the axis OctoMap's step chooses, as branches (speculation overlaps
  /// consecutive steps; a select chain would serialise them).
  template <class F>
  [[gnu::always_inline]] static decltype(auto) onLeastAxis(const double* t, F& go) {
    if (t[0] < t[1]) return t[0] < t[2] ? go.template operator()<0>() : go.template operator()<2>();
    return t[1] < t[2] ? go.template operator()<1>() : go.template operator()<2>();
  }
  template <int kAx>
  [[gnu::always_inline]] static bool chooses(const double* t) {
    constexpr int kO1 = (kAx + 1) % 3, kO2 = (kAx + 2) % 3;
    // Both comparisons, no branch between them (a bitwise and of their values, not &&).
    return (static_cast<unsigned>(before<kAx, kO1>(t[kAx], t[kO1])) &
            static_cast<unsigned>(before<kAx, kO2>(t[kAx], t[kO2]))) != 0u;
  }

  /// One step of OctoMap's loop: step along the axis of least t; stop on the end cell; stop when
  /// min(t) > length; mark. The axis the next step chooses holds min(t), so the length test is made there,
  /// before the mark of the cell it leaves, and the three-way minimum is not computed twice. kLeave: test
  /// and mark the cell being left (every step but the first, whose cell the caller marked). False: the
  /// walk has ended.
  template <int kSx, int kSy, int kSz, bool kLeave>
  [[gnu::always_inline]] bool advance(ForwardRay& s) {
    constexpr int kS[3] = {kSx, kSy, kSz};
    constexpr unsigned kM[3] = {kMortonX, kMortonY, kMortonZ};
    auto go = [&]<int kAx>() __attribute__((always_inline)) {
      if constexpr (kLeave) {
        if (s.t[kAx] > s.length) return false;
        markCell(s.target, s.m, s.k);
        ++s.visits;
      }
      step<kS[kAx], kM[kAx]>(s.target, s.k[kAx], s.m, s.k);
      s.t[kAx] += s.d[kAx];
      return true;
    };
    if (!onLeastAxis(s.t, go)) return false;
    return !(--s.steps_to_end == 0 && s.k[0] == s.e[0] && s.k[1] == s.e[1] && s.k[2] == s.e[2]);
  }

  /// One step of two walks in the same cell (`a` holds the position): kBothOn, or kDiverged when b would
  /// take another axis or either would stop on its length (nothing done: each then steps on its own), or
  /// kEndA / kEndB (or both) when the step reached a ray's end.
  static constexpr int kBothOn = 0, kEndA = 1, kEndB = 2, kDiverged = 4;
  template <int kSx, int kSy, int kSz, bool kLeave>
  [[gnu::always_inline]] int sharedStep(ForwardRay& a, ForwardRay& b) {
    constexpr int kS[3] = {kSx, kSy, kSz};
    constexpr unsigned kM[3] = {kMortonX, kMortonY, kMortonZ};
    auto go = [&]<int kAx>() __attribute__((always_inline)) {
      if (!chooses<kAx>(b.t)) return kDiverged;
      if constexpr (kLeave) {
        if ((a.t[kAx] > a.length) | (b.t[kAx] > b.length)) return kDiverged;
        markCell(a.target, a.m, a.k);
        ++a.visits;
        ++b.visits;
      }
      step<kS[kAx], kM[kAx]>(a.target, a.k[kAx], a.m, a.k);
      a.t[kAx] += a.d[kAx];
      b.t[kAx] += b.d[kAx];
      const bool end_a = --a.steps_to_end == 0 && a.k[0] == a.e[0] && a.k[1] == a.e[1] && a.k[2] == a.e[2];
      const bool end_b = --b.steps_to_end == 0 && a.k[0] == b.e[0] && a.k[1] == b.e[1] && a.k[2] == b.e[2];
      return (end_a ? kEndA : 0) | (end_b ? kEndB : 0);
    };
    return onLeastAxis(a.t, go);
  }

  // Bits of each axis in a block's Morton index (x in the lowest bit, see map::voxelIndexInBlock).
  static constexpr unsigned kMortonX = 0x249, kMortonY = kMortonX << 1, kMortonZ = kMortonX << 2;
  static_assert(map::kBlockShift == 4, "the Morton masks assume 16^3 blocks");

  template <int kS, unsigned kMask>
  [[gnu::always_inline]] void step(Target& c, int& k, unsigned& m, const int* ks) {
    // A step of -1 is a masked decrement, of +1 a masked increment; both wrap at the block's side, which
    // is exactly when the block changes. (An axis with no step is never stepped: the dispatch gives it
    // +1, and its crossing parameter stays at DBL_MAX forward, -infinity backward.)
    if constexpr (kS < 0) {
      k -= 1;
      m = (m & ~kMask) | (((m & kMask) - 1u) & kMask);
      if ((k & (map::kBlockSide - 1)) == map::kBlockSide - 1) [[unlikely]]
        enterBlock(c, ks[0], ks[1], ks[2]);
    } else {
      k += 1;
      m = (m & ~kMask) | (((m | ~kMask) + 1u) & kMask);
      if ((k & (map::kBlockSide - 1)) == 0) [[unlikely]]
        enterBlock(c, ks[0], ks[1], ks[2]);
    }
  }
  [[gnu::always_inline]] void enterBlock(Target& c, int kx, int ky, int kz) {
    map::EvidenceBlock* b = ev_.findBlock(key(kx, ky, kz));
    c = Target{b, b != nullptr ? planeOf(*b) : nullptr};
  }
  [[gnu::always_inline]] map::BitPlane* planeOf(map::EvidenceBlock& b) {
    if (lane_ >= 0) return &ev_.freeLane(lane_, b);
    return lane_ == kAlone ? &b.free : nullptr;
  }
  [[gnu::always_inline]] void markCell(Target& c, unsigned m, const int* ks) {
    if (c.plane != nullptr) [[likely]] {
      c.plane->set(static_cast<int>(m));  // no other thread writes this plane during the walks
    } else {
      c = markSlow(c, ks[0], ks[1], ks[2]);  // by value: the walk's state stays in registers
    }
  }
  /// First mark in a block this scan (allocates it), a cell outside the scan's box (overflow map), or a
  /// thread without a lane.
  [[gnu::noinline, gnu::cold]] Target markSlow(Target c, int kx, int ky, int kz) {
    const geometry::VoxelKey k = key(kx, ky, kz);
    if (c.block == nullptr && (c.block = ev_.block(k)) != nullptr) c.plane = planeOf(*c.block);
    if (c.plane != nullptr) {
      c.plane->set(map::voxelIndexInBlock(k));
    } else if (c.block != nullptr) {
      c.block->free.setAtomic(map::voxelIndexInBlock(k));
    } else {
      ev_.markFree(k);
    }
    return c;
  }
  /// Marks a finished walk's endpoint cell hit: where the walk ended in it (the usual case), through the
  /// block it holds, with no lookup. The hit planes are shared by all threads, hence the atomic set.
  void markEnd(const ForwardRay& s) {
    if (s.k[0] == s.e[0] && s.k[1] == s.e[1] && s.k[2] == s.e[2] && s.target.block != nullptr) [[likely]] {
      countEnd(s.target.block->hit.setAtomic(static_cast<int>(s.m)), s.walk_cells);
    } else {  // stopped short by OctoMap's length test, or the end cell's block is not allocated yet
      countEnd(markHitSlow(s.e[0], s.e[1], s.e[2]), s.walk_cells);
    }
  }
  void countEnd(bool first, int walk_cells) {
    if (first) {
      ++ends_.first_hits;
    } else {
      ends_.shared_walks += static_cast<std::uint64_t>(walk_cells);
    }
  }
  /// As map::EvidenceCursor::markHit: true when the cell had no hit yet (cells outside the box: false).
  [[gnu::noinline, gnu::cold]] bool markHitSlow(int kx, int ky, int kz) {
    const geometry::VoxelKey k = key(kx, ky, kz);
    if (map::EvidenceBlock* b = ev_.block(k)) return b->hit.setAtomic(map::voxelIndexInBlock(k));
    ev_.markHit(k);
    return false;
  }

  static geometry::VoxelKey key(int kx, int ky, int kz) {
    return geometry::VoxelKey{{static_cast<geometry::KeyCoord>(kx), static_cast<geometry::KeyCoord>(ky),
                               static_cast<geometry::KeyCoord>(kz)}};
  }

  map::ScanEvidence& ev_;
  int lane_;
  Target cur_;  // the backward walks' block
  EndCounts ends_;
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
