// Per-scan evidence: which cells the scan's rays crossed and hit (batch semantics: one flag byte per cell)
// or how many times (counting semantics: counters), plus the scan's culling region. Stored in 8^3 blocks
// addressed through a dense directory over the scan's bounding box, so the hot ray walks find a cell with a
// few integer operations and no hashing, from many threads.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <unordered_map>
#include <utility>
#include <vector>

#include "densemap/geometry/voxel_key.h"
#include "densemap/util/huge_page_buffer.h"

namespace densemap::map {

using geometry::VoxelKey;

inline constexpr int kBlockShift = 4;
inline constexpr int kBlockSide = 1 << kBlockShift;
inline constexpr int kBlockVoxels = kBlockSide * kBlockSide * kBlockSide;

/// Voxels inside a block are stored in Morton (z-order) order, x in the lowest bit: listing a block's voxels
/// by index then visits them in OctoMap's child order, and cells close in space stay close in memory.
namespace detail {
constexpr std::array<std::uint16_t, kBlockSide> makeSpread() {
  std::array<std::uint16_t, kBlockSide> t{};
  for (int v = 0; v < kBlockSide; ++v) {
    int r = 0;
    for (int b = 0; b < kBlockShift; ++b) r |= ((v >> b) & 1) << (3 * b);
    t[static_cast<std::size_t>(v)] = static_cast<std::uint16_t>(r);
  }
  return t;
}
inline constexpr std::array<std::uint16_t, kBlockSide> kSpread = makeSpread();
/// Gathers bits 0, 3, 6 and 9 of m into bits 0-3 (the inverse of kSpread), with shifts instead of a loop:
/// block listings call it for every cell of a scan.
constexpr int compact(int m) {
  static_assert(kBlockShift == 4);
  int v = m & 0x249;
  v = (v | (v >> 2)) & 0x0C3;     // bits 0,3,6,9 -> 0,1,6,7
  return (v | (v >> 4)) & 0x00F;  // -> 0,1,2,3
}
constexpr bool compactInvertsSpread() {
  for (int v = 0; v < kBlockSide; ++v)
    if (compact(kSpread[static_cast<std::size_t>(v)]) != v) return false;
  return true;
}
static_assert(compactInvertsSpread());
}  // namespace detail

inline int voxelIndexInBlock(const VoxelKey& key) {
  constexpr int m = kBlockSide - 1;
  return detail::kSpread[static_cast<std::size_t>(key[0] & m)] |
         (detail::kSpread[static_cast<std::size_t>(key[1] & m)] << 1) |
         (detail::kSpread[static_cast<std::size_t>(key[2] & m)] << 2);
}

/// Offset of voxel index i from its block's lowest voxel.
constexpr std::array<int, 3> voxelOffsetInBlock(int i) {
  return {detail::compact(i), detail::compact(i >> 1), detail::compact(i >> 2)};
}

/// One bit per voxel of a block.
struct BitPlane {
  std::array<std::uint64_t, kBlockVoxels / 64> words;
  bool test(int i) const { return (words[static_cast<std::size_t>(i >> 6)] >> (i & 63)) & 1u; }
  void set(int i) { words[static_cast<std::size_t>(i >> 6)] |= std::uint64_t{1} << (i & 63); }
  void reset(int i) { words[static_cast<std::size_t>(i >> 6)] &= ~(std::uint64_t{1} << (i & 63)); }
  /// Thread-safe set: a plain load first, so already-set bits (the common case) cost no locked operation.
  /// True when this call set the bit.
  [[gnu::always_inline]] bool setAtomic(int i) {
    std::atomic_ref<std::uint64_t> w(words[static_cast<std::size_t>(i >> 6)]);
    const std::uint64_t bit = std::uint64_t{1} << (i & 63);
    if (w.load(std::memory_order_relaxed) & bit) return false;
    return !(w.fetch_or(bit, std::memory_order_relaxed) & bit);
  }
  [[gnu::always_inline]] bool testAtomic(int i) const {
    return (std::atomic_ref<const std::uint64_t>(words[static_cast<std::size_t>(i >> 6)])
                .load(std::memory_order_relaxed) >>
            (i & 63)) &
           1u;
  }
  bool any() const {
    std::uint64_t a = 0;
    for (auto w : words) a |= w;
    return a != 0;
  }
  void clear() { words.fill(0); }
};

struct EvidenceBlock {
  BitPlane free;     ///< crossed by at least one ray
  BitPlane hit;      ///< holds at least one endpoint
  BitPlane region;   ///< in the culling region
  BitPlane closed;   ///< in the in-scan closed region (batch semantics)
  BitPlane visited;  ///< culling-region search bookkeeping
  BitPlane seen;     ///< closed-region search bookkeeping
  /// Counting semantics only: n_free, n_hit per voxel, kept apart from the bit planes so the planes of
  /// neighbouring blocks stay close in memory (the hot ray walks touch only the planes).
  struct Counters {
    std::array<std::uint32_t, kBlockVoxels> n_free;
    std::array<std::uint32_t, kBlockVoxels> n_hit;
  };
  Counters* counters = nullptr;
  VoxelKey base;         ///< key of the block's lowest voxel
  std::uint32_t id = 0;  ///< allocation index in its ScanEvidence (its free lanes' index)
  bool installed = false;

  void clear(bool clear_counters, bool regions = true) {
    free.clear();
    hit.clear();
    if (regions) {
      region.clear();
      closed.clear();
      visited.clear();
      seen.clear();
    }
    if (clear_counters && counters) {
      counters->n_free.fill(0);
      counters->n_hit.fill(0);
    }
    installed = false;
  }
  bool hasEvidence() const { return free.any() || hit.any(); }
  /// Calls f(i) for every voxel with evidence (free or hit), in index order, skipping empty words.
  template <class F>
  void forEachEvidenceVoxel(F&& f) const {
    for (std::size_t w = 0; w < free.words.size(); ++w) {
      std::uint64_t bits = free.words[w] | hit.words[w];
      while (bits) {
        const int b = __builtin_ctzll(bits);
        bits &= bits - 1;
        f(static_cast<int>(w * 64) + b);
      }
    }
  }
  bool hasEvidence(int i) const { return free.test(i) || hit.test(i); }
  VoxelKey voxelKey(int i) const {
    const auto d = voxelOffsetInBlock(i);
    return VoxelKey{{static_cast<geometry::KeyCoord>(base[0] + d[0]),
                     static_cast<geometry::KeyCoord>(base[1] + d[1]),
                     static_cast<geometry::KeyCoord>(base[2] + d[2])}};
  }
};

class ScanEvidence {
 public:
  ScanEvidence();
  ~ScanEvidence();
  ScanEvidence(const ScanEvidence&) = delete;
  ScanEvidence& operator=(const ScanEvidence&) = delete;

  /// Starts a new scan whose cells all lie in [min_key, max_key] (inclusive). Cells outside that box can
  /// still be recorded (they go to a slower overflow map), so a loose box is only a performance matter.
  /// `counting` selects counters (counting semantics) over flags (batch semantics).
  void reset(const VoxelKey& min_key, const VoxelKey& max_key, bool counting);
  bool counting() const { return counting_; }

  /// Thread-safe: adds `w` free traversals (or hits) to a cell (counting semantics).
  void addFree(const VoxelKey& key, std::uint32_t w);
  void addHit(const VoxelKey& key, std::uint32_t w);
  /// Thread-safe: marks a cell as crossed / hit (batch semantics).
  void markFree(const VoxelKey& key);
  void markHit(const VoxelKey& key);

  /// The block holding `key`, or null if nothing was recorded there (or it lies outside the box). Forced
  /// inline (GCC kept it out of line in the eight walk instantiations): the ray walks call it whenever a
  /// ray enters a block, and a call there makes the compiler spill the walk's floating-point state.
  [[gnu::always_inline]] EvidenceBlock* findBlock(const VoxelKey& key) const {
    const auto* s = slot(key);
    return s ? s->load(std::memory_order_acquire) : nullptr;
  }
  /// The block holding `key`, created if needed; null only outside the box.
  EvidenceBlock* block(const VoxelKey& key);

  bool inRegion(const VoxelKey& key) const {
    const EvidenceBlock* b = findBlock(key);
    return b != nullptr && b->region.test(voxelIndexInBlock(key));
  }
  bool insideBox(const VoxelKey& key) const;

  /// n_free and n_hit of voxel i of a block, under this scan's semantics.
  std::pair<std::uint32_t, std::uint32_t> counts(const EvidenceBlock& b, int i) const {
    const auto u = static_cast<std::size_t>(i);
    if (counting_) return {b.counters->n_free[u], b.counters->n_hit[u]};
    return {b.free.test(i) ? 1u : 0u, b.hit.test(i) ? 1u : 0u};
  }

  template <class F>
  void forEachBlock(F&& f) const {
    const std::size_t n = blockCount();
    for (std::size_t i = 0; i < n; ++i) {
      const EvidenceBlock& b = blockAt(i);
      if (b.installed) f(b);
    }
  }
  std::size_t blockCount() const;
  const EvidenceBlock& blockAt(std::size_t i) const;
  EvidenceBlock& blockAt(std::size_t i);
  /// Cells recorded outside the box (normally none).
  std::size_t overflowCount() const { return overflow_.size(); }
  template <class F>
  void forEachOverflowCell(F&& f) const {
    for (const auto& [key, c] : overflow_) f(key, c.first, c.second);
  }

  /// Batch semantics: a cell both hit and crossed in one scan counts as hit only ("occupied wins").
  void resolveOccupiedWins();
  /// Distinct cells outside the box holding at least one endpoint (the cursor's markHit / addHit count
  /// those inside).
  std::uint64_t overflowHitCells() const;

  /// Free lanes: a team of threads marking free cells, each in its own copy of the blocks' free planes, so
  /// that no mark needs a locked instruction (shared planes need one for each cell's first mark of a scan).
  /// Thread `lane` (< kMaxFreeLanes; more threads mark the shared planes with locked operations) owns its
  /// lane; the caller merges after the team has finished, before anything reads the free planes. Each lane
  /// costs a free plane per block (a sixth of a block), so their number is capped.
  static constexpr int kMaxFreeLanes = 16;
  [[gnu::always_inline]] BitPlane& freeLane(int lane, const EvidenceBlock& b) {
    auto& planes = chunk_ptrs_[b.id / kChunkBlocks]
                       .load(std::memory_order_relaxed)
                       ->lanes[static_cast<std::size_t>(lane)];
    if (!planes) [[unlikely]]
      allocateLane(lane, planes);
    return planes[b.id % kChunkBlocks];
  }
  /// ORs every lane into the blocks' free planes and clears the lanes.
  void mergeFreeLanes();

 private:
  static constexpr std::size_t kChunkBlocks = 1024;
  static constexpr std::size_t kMaxChunks = 4096;
  /// Blocks live in huge-page mappings (EvidenceBlock is trivially constructible: zeroed memory is a valid
  /// empty block).
  struct Chunk {
    util::HugePageBuffer memory;
    EvidenceBlock* blocks;
    std::unique_ptr<std::array<EvidenceBlock::Counters, kChunkBlocks>> counters;  // counting semantics
    /// Lane t's free planes of this chunk's blocks, allocated by thread t on its first mark here; all zero
    /// between scans (the merge clears them).
    std::array<std::unique_ptr<BitPlane[]>, kMaxFreeLanes> lanes;
    explicit Chunk(std::size_t index);
  };
  std::size_t capacity() const { return kChunkBlocks * kMaxChunks; }
  EvidenceBlock* allocate();
  [[gnu::always_inline]] std::atomic<EvidenceBlock*>* slot(const VoxelKey& key) const {
    const int bx = (key[0] >> kBlockShift) - lo_[0];
    const int by = (key[1] >> kBlockShift) - lo_[1];
    const int bz = (key[2] >> kBlockShift) - lo_[2];
    if (static_cast<unsigned>(bx) >= static_cast<unsigned>(dims_[0]) ||
        static_cast<unsigned>(by) >= static_cast<unsigned>(dims_[1]) ||
        static_cast<unsigned>(bz) >= static_cast<unsigned>(dims_[2]))
      return nullptr;
    const std::size_t idx =
        (static_cast<std::size_t>(bx) * static_cast<std::size_t>(dims_[1]) + static_cast<std::size_t>(by)) *
            static_cast<std::size_t>(dims_[2]) +
        static_cast<std::size_t>(bz);
    return &directory_[idx];
  }
  void addOverflow(const VoxelKey& key, std::uint32_t nf, std::uint32_t nh, bool saturate);
  [[gnu::noinline, gnu::cold]] void allocateLane(int lane, std::unique_ptr<BitPlane[]>& planes);

  bool counting_ = false;
  bool counters_dirty_ = false;  // counters of reused blocks may be non-zero
  bool regions_dirty_ = true;    // region planes of reused blocks may be non-zero

 public:
  /// Region searches call this before setting region planes, so reset() knows to clear them.
  void noteRegionsUsed() { regions_dirty_ = true; }

 private:
  int lo_[3] = {0, 0, 0};  // box origin in block units
  int dims_[3] = {0, 0, 0};
  std::unique_ptr<std::atomic<EvidenceBlock*>[]> directory_;
  std::size_t directory_size_ = 0;
  std::size_t directory_capacity_ = 0;
  std::vector<std::unique_ptr<Chunk>> chunks_;  // sized kMaxChunks up front: never reallocates
  std::unique_ptr<std::atomic<Chunk*>[]> chunk_ptrs_;
  std::atomic<std::size_t> used_{0};
  std::mutex chunk_mutex_;
  std::mutex overflow_mutex_;
  std::atomic<int> lanes_used_{0};  // 1 + the highest lane ever allocated
  std::unordered_map<VoxelKey, std::pair<std::uint32_t, std::uint32_t>, geometry::VoxelKeyHash> overflow_;
};

/// A per-thread accessor for the hot ray walks: remembers the last block, so consecutive cells of a ray
/// (8 per block side) cost one directory lookup instead of one each.
class EvidenceCursor {
 public:
  explicit EvidenceCursor(ScanEvidence& ev) : ev_(ev) {}

  /// The block of `key` if it exists (never allocates).
  [[gnu::always_inline]] EvidenceBlock* find(const VoxelKey& key) {
    // Same block as last time when the key differs from the cached one only in the low (in-block) bits.
    if ((((key[0] ^ k0_) | (key[1] ^ k1_) | (key[2] ^ k2_)) >> kBlockShift) != 0 || !valid_) {
      k0_ = key[0];
      k1_ = key[1];
      k2_ = key[2];
      valid_ = true;
      block_ = ev_.findBlock(key);
    }
    return block_;
  }
  /// The block of `key`, allocated if needed; null only outside the scan's box.
  [[gnu::always_inline]] EvidenceBlock* get(const VoxelKey& key) {
    EvidenceBlock* b = find(key);
    if (b == nullptr) [[unlikely]]
      b = allocate(key);
    return b;
  }
  /// Membership of `key` in a bit plane of its block (false where no block exists).
  template <BitPlane EvidenceBlock::*kPlane>
  [[gnu::always_inline]] bool has(const VoxelKey& key) {
    const EvidenceBlock* b = find(key);
    return b != nullptr && (b->*kPlane).testAtomic(voxelIndexInBlock(key));
  }
  [[gnu::always_inline]] bool inRegion(const VoxelKey& key) { return has<&EvidenceBlock::region>(key); }
  [[gnu::always_inline]] void markFree(const VoxelKey& key) {
    if (EvidenceBlock* b = get(key)) [[likely]] {
      b->free.setAtomic(voxelIndexInBlock(key));
    } else {
      markOverflow(key, false);
    }
  }
  /// True when the cell had no hit yet this scan (inside the box; cells outside it: false).
  [[gnu::always_inline]] bool markHit(const VoxelKey& key) {
    if (EvidenceBlock* b = get(key)) [[likely]]
      return b->hit.setAtomic(voxelIndexInBlock(key));
    markOverflow(key, true);
    return false;
  }
  /// True as markHit.
  [[gnu::always_inline]] bool addHit(const VoxelKey& key, std::uint32_t w) {
    if (EvidenceBlock* b = get(key)) {
      const int i = voxelIndexInBlock(key);
      std::atomic_ref<std::uint32_t>(b->counters->n_hit[static_cast<std::size_t>(i)])
          .fetch_add(w, std::memory_order_relaxed);
      return b->hit.setAtomic(i);
    }
    ev_.addHit(key, w);
    return false;
  }
  [[gnu::always_inline]] void addFree(const VoxelKey& key, std::uint32_t w) {
    if (EvidenceBlock* b = get(key)) {
      const int i = voxelIndexInBlock(key);
      std::atomic_ref<std::uint32_t>(b->counters->n_free[static_cast<std::size_t>(i)])
          .fetch_add(w, std::memory_order_relaxed);
      b->free.setAtomic(i);
    } else {
      ev_.addFree(key, w);
    }
  }

 private:
  // The rare paths stay out of line and cold, so the walks keep their state in registers.
  [[gnu::noinline, gnu::cold]] EvidenceBlock* allocate(const VoxelKey& key) {
    return block_ = ev_.block(key);
  }
  [[gnu::noinline, gnu::cold]] void markOverflow(const VoxelKey& key, bool hit) {
    if (hit) {
      ev_.markHit(key);
    } else {
      ev_.markFree(key);
    }
  }

  ScanEvidence& ev_;
  unsigned k0_ = 0, k1_ = 0, k2_ = 0;
  bool valid_ = false;
  EvidenceBlock* block_ = nullptr;
};

}  // namespace densemap::map
