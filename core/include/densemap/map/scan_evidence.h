// Per-scan evidence: how many rays crossed (n_free) and hit (n_hit) each cell during one scan, plus the
// scan's culling region. Stored in 8^3 blocks addressed through a dense directory over the scan's bounding
// box, so the hot ray walks find a cell with a few integer operations and no hashing, from many threads.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <unordered_map>
#include <vector>

#include "densemap/geometry/voxel_key.h"

namespace densemap::map {

using geometry::VoxelKey;

inline constexpr int kBlockShift = 3;
inline constexpr int kBlockSide = 1 << kBlockShift;
inline constexpr int kBlockVoxels = kBlockSide * kBlockSide * kBlockSide;

inline int voxelIndexInBlock(const VoxelKey& key) {
  constexpr int m = kBlockSide - 1;
  return (key[0] & m) | ((key[1] & m) << kBlockShift) | ((key[2] & m) << (2 * kBlockShift));
}

struct EvidenceBlock {
  std::array<std::uint32_t, kBlockVoxels> n_free;
  std::array<std::uint32_t, kBlockVoxels> n_hit;
  std::array<std::uint64_t, kBlockVoxels / 64> region;   ///< culling-region membership
  std::array<std::uint64_t, kBlockVoxels / 64> visited;  ///< culling-region search bookkeeping
  VoxelKey base;                                          ///< key of the block's lowest voxel
  bool installed = false;

  void clear() {
    n_free.fill(0);
    n_hit.fill(0);
    region.fill(0);
    visited.fill(0);
    installed = false;
  }
  static bool testBit(const std::array<std::uint64_t, kBlockVoxels / 64>& bits, int i) {
    return (bits[static_cast<std::size_t>(i >> 6)] >> (i & 63)) & 1u;
  }
  static void setBit(std::array<std::uint64_t, kBlockVoxels / 64>& bits, int i) {
    bits[static_cast<std::size_t>(i >> 6)] |= std::uint64_t{1} << (i & 63);
  }
};

class ScanEvidence {
 public:
  ScanEvidence();
  ~ScanEvidence();
  ScanEvidence(const ScanEvidence&) = delete;
  ScanEvidence& operator=(const ScanEvidence&) = delete;

  /// Starts a new scan whose cells all lie in [min_key, max_key] (inclusive). Cells outside that box can
  /// still be recorded (they go to a slower overflow list), so a loose box is only a performance matter.
  void reset(const VoxelKey& min_key, const VoxelKey& max_key);

  /// Thread-safe: adds `w` free traversals (or hits) to a cell.
  void addFree(const VoxelKey& key, std::uint32_t w);
  void addHit(const VoxelKey& key, std::uint32_t w);
  /// Thread-safe: marks a cell as crossed / hit at least once (batch semantics: counts saturate at 1).
  void markFree(const VoxelKey& key);
  void markHit(const VoxelKey& key);

  /// The block holding `key`, or null if nothing was recorded there (or it lies outside the box).
  EvidenceBlock* findBlock(const VoxelKey& key) const;
  /// The block holding `key`, created if needed; null only outside the box.
  EvidenceBlock* block(const VoxelKey& key);

  bool inRegion(const VoxelKey& key) const {
    const EvidenceBlock* b = findBlock(key);
    return b != nullptr && EvidenceBlock::testBit(b->region, voxelIndexInBlock(key));
  }
  bool insideBox(const VoxelKey& key) const;

  /// Calls f(key, n_free, n_hit) for every cell with evidence; blocks in ascending block order is not
  /// guaranteed. Not thread-safe against concurrent writers.
  template <class F>
  void forEachCell(F&& f) const {
    forEachBlock([&](const EvidenceBlock& b) {
      for (int i = 0; i < kBlockVoxels; ++i) {
        const auto nf = b.n_free[static_cast<std::size_t>(i)];
        const auto nh = b.n_hit[static_cast<std::size_t>(i)];
        if (nf == 0 && nh == 0) continue;
        VoxelKey k = b.base;
        k[0] = static_cast<geometry::KeyCoord>(k[0] + (i & (kBlockSide - 1)));
        k[1] = static_cast<geometry::KeyCoord>(k[1] + ((i >> kBlockShift) & (kBlockSide - 1)));
        k[2] = static_cast<geometry::KeyCoord>(k[2] + (i >> (2 * kBlockShift)));
        f(k, nf, nh);
      }
    });
    for (const auto& [key, counts] : overflow_) f(key, counts.first, counts.second);
  }

  template <class F>
  void forEachBlock(F&& f) const {
    const std::size_t n = std::min<std::size_t>(used_.load(std::memory_order_acquire), capacity());
    for (std::size_t i = 0; i < n; ++i) {
      const EvidenceBlock& b = blockAt(i);
      if (b.installed) f(b);
    }
  }
  std::size_t blockCount() const;
  const EvidenceBlock& blockAt(std::size_t i) const;

  /// Batch semantics: a cell both hit and crossed in one scan counts as hit only ("occupied wins").
  void resolveOccupiedWins();
  /// Cells recorded outside the box (normally none).
  std::size_t overflowCount() const { return overflow_.size(); }

 private:
  static constexpr std::size_t kChunkBlocks = 256;
  static constexpr std::size_t kMaxChunks = 16384;
  struct Chunk {
    std::array<EvidenceBlock, kChunkBlocks> blocks;
  };
  std::size_t capacity() const { return kChunkBlocks * kMaxChunks; }
  EvidenceBlock* allocate();
  std::atomic<EvidenceBlock*>* slot(const VoxelKey& key) const;
  void addOverflow(const VoxelKey& key, std::uint32_t nf, std::uint32_t nh, bool saturate);

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
  std::unordered_map<VoxelKey, std::pair<std::uint32_t, std::uint32_t>, geometry::VoxelKeyHash> overflow_;
};

/// A per-thread accessor for the hot ray walks: remembers the last block, so consecutive cells of a ray
/// (8 per block side) cost one directory lookup instead of one each.
class EvidenceCursor {
 public:
  explicit EvidenceCursor(ScanEvidence& ev) : ev_(ev) {}

  /// The block of `key` if it exists (never allocates).
  EvidenceBlock* find(const VoxelKey& key) {
    const std::uint64_t bk = blockKey(key);
    if (bk != key_) {
      key_ = bk;
      block_ = ev_.findBlock(key);
    }
    return block_;
  }
  /// The block of `key`, allocated if needed; null only outside the scan's box.
  EvidenceBlock* get(const VoxelKey& key) {
    EvidenceBlock* b = find(key);
    if (b == nullptr) block_ = b = ev_.block(key);
    return b;
  }
  bool inRegion(const VoxelKey& key) {
    const EvidenceBlock* b = find(key);
    return b != nullptr && EvidenceBlock::testBit(b->region, voxelIndexInBlock(key));
  }
  void markFree(const VoxelKey& key) {
    if (EvidenceBlock* b = get(key)) {
      std::atomic_ref<std::uint32_t> c(b->n_free[static_cast<std::size_t>(voxelIndexInBlock(key))]);
      if (c.load(std::memory_order_relaxed) == 0) c.store(1, std::memory_order_relaxed);
    } else {
      ev_.markFree(key);
    }
  }
  void addFree(const VoxelKey& key, std::uint32_t w) {
    if (EvidenceBlock* b = get(key)) {
      std::atomic_ref<std::uint32_t>(b->n_free[static_cast<std::size_t>(voxelIndexInBlock(key))])
          .fetch_add(w, std::memory_order_relaxed);
    } else {
      ev_.addFree(key, w);
    }
  }

 private:
  static std::uint64_t blockKey(const VoxelKey& k) {
    return (std::uint64_t{static_cast<std::uint16_t>(k[0] >> kBlockShift)} << 32) |
           (std::uint64_t{static_cast<std::uint16_t>(k[1] >> kBlockShift)} << 16) |
           std::uint64_t{static_cast<std::uint16_t>(k[2] >> kBlockShift)};
  }
  ScanEvidence& ev_;
  std::uint64_t key_ = ~std::uint64_t{0};
  EvidenceBlock* block_ = nullptr;
};

}  // namespace densemap::map
