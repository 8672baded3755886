// A uniform 3D grid stored as hashed 16^3 blocks of voxels (palette_block.h: a byte per voxel into the
// block's distinct values): no allocation per voxel, and a whole block is updated at once from the scan's
// evidence.
#pragma once

#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <span>
#include <unordered_map>
#include <vector>

#include "densemap/map/block_id_map.h"
#include "densemap/map/decay.h"
#include "densemap/map/occupancy_map.h"
#include "densemap/map/palette_block.h"

namespace densemap::map {

class GridMap : public OccupancyMap {
 public:
  /// Log-odds per voxel; NaN marks a voxel never observed.
  using Block = PaletteBlock;

  GridMap(double resolution, const OccupancyParams& params = {}) : OccupancyMap(resolution, params) {}

  std::string backendName() const override { return "grid"; }
  void apply(const ScanEvidence& evidence) override;
  /// Copy-on-write per block: the scan's blocks are updated in copies, then swapped in by `publish`.
  void applyPublished(const ScanEvidence& evidence, const Publisher& publish) override;
  std::optional<float> logOdds(const VoxelKey& key) const override;
  void logOddsMany(std::span<const VoxelKey> keys, std::span<float> out) const override;
  bool isFullyFree(const VoxelKey& key) const override;
  std::size_t knownCells() const override;
  std::size_t memoryBytes() const override;
  void forEachCell(const std::function<void(const VoxelKey&, float)>& f) const override;
  void forEachCellInBox(const VoxelKey& lo, const VoxelKey& hi,
                        const std::function<void(const VoxelKey&, float)>& f) const override;
  std::size_t eraseBox(const VoxelKey& lo, const VoxelKey& hi) override;
  void clear() override {
    blocks_.clear();
    out_of_memory_.clear();
  }
  bool advanceTime(double now_s, const Publisher& publish) override;

  /// Turns decay on (or off, with seconds_to_unknown 0). Throws std::invalid_argument when invalid.
  void setDecay(const DecayOptions& decay);
  const DecayOptions& decay() const { return decay_; }
  /// Every block's values are current at the map time (snapshots keep it, so a restart decays as the
  /// uninterrupted run would).
  double mapTime() const override { return decay_clock_s_; }
  void setMapTime(double t_s) override;
  std::unique_ptr<OccupancyMap> clone() const override;
  /// Sets one cell's log-odds (loading a saved map; not for scans, which go through apply()).
  void setLogOdds(const VoxelKey& key, float log_odds);

  /// Bitwise comparison of two grids (same known cells, same float bits).
  bool identical(const GridMap& other, std::string* why = nullptr) const;

  const Block* findBlock(const VoxelKey& key) const;
  static std::uint64_t blockIdOf(const VoxelKey& key) { return blockId(key); }
  /// True for the ids blockIdOf can return (block coordinates below 2^(16 - kBlockShift)).
  static bool isBlockId(std::uint64_t id) {
    constexpr std::uint64_t kCoordBits = ~std::uint64_t{0xFFFF >> kBlockShift} & 0xFFFF;
    return (id >> 48) == 0 && (id & (kCoordBits << 32 | kCoordBits << 16 | kCoordBits)) == 0;
  }
  const Block* blockById(std::uint64_t id) const {
    auto it = blocks_.find(id);
    return it == blocks_.end() ? nullptr : it->second.get();
  }

  /// Blocks out of memory (the rolling window and memory cap): takeBlock removes a block and
  /// remembers that its cells exist elsewhere; putBlock brings it back. A scan must not change a block
  /// that is out of memory (apply throws std::logic_error: bring it back first, outOfMemoryIn finds them),
  /// and queries answer "unknown" there unless the caller checks inMemory.
  std::unique_ptr<Block> takeBlock(std::uint64_t id);
  void putBlock(std::uint64_t id, std::unique_ptr<Block> block);
  /// Marks a block out of memory whose bytes are elsewhere (a restart: a snapshot's stored blocks).
  void markOutOfMemory(std::uint64_t id) {
    blocks_.erase(id);
    out_of_memory_.insert(id);
  }
  bool inMemory(const VoxelKey& key) const { return !out_of_memory_.contains(blockId(key)); }
  std::size_t outOfMemoryCount() const { return out_of_memory_.size(); }
  /// Out-of-memory blocks with a cell in [lo, hi].
  std::vector<std::uint64_t> outOfMemoryIn(const VoxelKey& lo, const VoxelKey& hi) const;
  /// In-memory blocks whose centre is farther than `radius` metres from every one of `centres`.
  std::vector<std::uint64_t> blocksFartherThan(std::span<const geometry::Vec3f> centres, double radius) const;
  /// The least recently updated in-memory blocks, oldest first, until their bytes reach `bytes`; blocks
  /// the last scan changed are never among them.
  std::vector<std::uint64_t> leastRecentlyUpdated(std::size_t bytes) const;
  /// Scans applied so far (PaletteBlock::last_scan counts in these).
  std::uint64_t scansApplied() const { return scans_; }
  std::size_t blockCount() const { return blocks_.size(); }
  /// Blocks that keep a float per voxel (more than 256 distinct values at once; palette_block.h).
  std::size_t denseBlockCount() const;

 private:
  void applyOverflow(const ScanEvidence& evidence);
  /// The block coordinates of a voxel key; packed, they are the block's id.
  static VoxelKey blockKey(const VoxelKey& key) {
    return VoxelKey{{static_cast<geometry::KeyCoord>(key[0] >> kBlockShift),
                     static_cast<geometry::KeyCoord>(key[1] >> kBlockShift),
                     static_cast<geometry::KeyCoord>(key[2] >> kBlockShift)}};
  }
  static std::uint64_t blockId(const VoxelKey& key) { return blockKey(key).packed(); }
  /// A new block is current at the last decay step (it takes the whole next step's decay).
  double newBlockTime() const { return std::isnan(decay_clock_s_) ? 0.0 : decay_clock_s_; }
  std::unique_ptr<Block> newBlock() const {
    auto b = std::make_unique<Block>();
    b->time_s = newBlockTime();
    return b;
  }
  /// Throws std::logic_error when block `id` is out of memory (a scan would overwrite what is stored).
  void requireInMemory(std::uint64_t id) const;

  DecayOptions decay_{};
  double decay_clock_s_ = std::numeric_limits<double>::quiet_NaN();
  std::unordered_map<std::uint64_t, std::unique_ptr<Block>> blocks_;
  BlockIdSet out_of_memory_;  // a few bytes per block: it lives as long as the server
  std::uint64_t scans_ = 0;
  std::vector<std::unique_ptr<Block>> spare_;  // blocks swapped out by applyPublished, reused as copies
};

}  // namespace densemap::map
