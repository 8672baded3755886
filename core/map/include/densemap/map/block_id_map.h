// Block ids (packed VoxelKeys of block coordinates, grid_map.h) grouped by regions of 4x4x4 blocks: a
// 64-bit mask per region says which of its blocks are present, and the values of those blocks follow in
// bit order. Why: the rolling window keeps an entry per block stored out of memory for as long
// as the server runs; a hash node per block (about 50 bytes with the allocator's) made the server's memory
// grow with the distance driven. Blocks stored along a trajectory are neighbours, so a region carries many
// and an entry costs its value plus a few bytes. The regions also answer "which entries lie in this box"
// without visiting every entry.
#pragma once

#include <bit>
#include <cstddef>
#include <cstdint>
#include <type_traits>
#include <unordered_map>
#include <vector>

#include "densemap/geometry/voxel_key.h"

namespace densemap::map {

/// Value = void for a set.
template <class Value>
class BlockIdMap {
  static constexpr bool kHasValues = !std::is_void_v<Value>;
  using Stored = std::conditional_t<kHasValues, Value, char>;

 public:
  /// True when `id` was not there before. Overwrites the value when it was.
  bool insert(std::uint64_t id, const Stored& value = Stored{}) {
    Region& r = regions_[regionOf(id)];
    const std::uint64_t bit = std::uint64_t{1} << bitOf(id);
    const auto rank = static_cast<std::ptrdiff_t>(std::popcount(r.mask & (bit - 1)));
    if (r.mask & bit) {
      if constexpr (kHasValues) r.values[static_cast<std::size_t>(rank)] = value;
      return false;
    }
    r.mask |= bit;
    if constexpr (kHasValues) {
      // Grow by a quarter, not double: these vectors live as long as the server.
      if (r.values.size() == r.values.capacity()) r.values.reserve(r.values.size() + r.values.size() / 4 + 1);
      r.values.insert(r.values.begin() + rank, value);
    }
    ++size_;
    return true;
  }

  bool erase(std::uint64_t id) {
    auto it = regions_.find(regionOf(id));
    if (it == regions_.end()) return false;
    Region& r = it->second;
    const std::uint64_t bit = std::uint64_t{1} << bitOf(id);
    if (!(r.mask & bit)) return false;
    if constexpr (kHasValues) {
      const auto rank = static_cast<std::ptrdiff_t>(std::popcount(r.mask & (bit - 1)));
      r.values.erase(r.values.begin() + rank);
    }
    r.mask &= ~bit;
    if (r.mask == 0) regions_.erase(it);
    --size_;
    return true;
  }

  bool contains(std::uint64_t id) const {
    auto it = regions_.find(regionOf(id));
    return it != regions_.end() && (it->second.mask >> bitOf(id) & 1u);
  }

  /// The value of `id`, or null.
  const Stored* find(std::uint64_t id) const requires kHasValues {
    auto it = regions_.find(regionOf(id));
    if (it == regions_.end()) return nullptr;
    const Region& r = it->second;
    const std::uint64_t bit = std::uint64_t{1} << bitOf(id);
    if (!(r.mask & bit)) return nullptr;
    return &r.values[static_cast<std::size_t>(std::popcount(r.mask & (bit - 1)))];
  }

  std::size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  void clear() {
    regions_.clear();
    size_ = 0;
  }

  /// f(id) for a set, f(id, value) for a map; in no particular order.
  template <class F>
  void forEach(F&& f) const {
    for (const auto& [key, r] : regions_) visit(key, r, ~std::uint64_t{0}, f);
  }

  /// As forEach, for the ids whose block coordinates lie in [lo, hi] (inclusive, per axis). Looks up the
  /// regions the box covers, or visits every region when there are fewer of those.
  template <class F>
  void forEachInBox(const geometry::VoxelKey& lo, const geometry::VoxelKey& hi, F&& f) const {
    std::uint64_t regions_in_box = 1;
    for (int a = 0; a < 3; ++a) {
      if (lo[a] > hi[a]) return;
      regions_in_box *= static_cast<std::uint64_t>((hi[a] >> kShift) - (lo[a] >> kShift) + 1);
    }
    auto inBox = [&](std::uint64_t id) {
      const geometry::VoxelKey b = geometry::VoxelKey::fromPacked(id);
      for (int a = 0; a < 3; ++a)
        if (b[a] < lo[a] || b[a] > hi[a]) return false;
      return true;
    };
    auto visitRegion = [&](std::uint64_t key, const Region& r) {
      std::uint64_t mask = r.mask;
      for (std::uint64_t m = mask; m != 0; m &= m - 1) {
        const int bit = std::countr_zero(m);
        if (!inBox(idOf(key, bit))) mask &= ~(std::uint64_t{1} << bit);
      }
      visit(key, r, mask, f);
    };
    if (regions_in_box >= regions_.size()) {
      for (const auto& [key, r] : regions_) visitRegion(key, r);
      return;
    }
    for (int x = lo[0] >> kShift; x <= hi[0] >> kShift; ++x)
      for (int y = lo[1] >> kShift; y <= hi[1] >> kShift; ++y)
        for (int z = lo[2] >> kShift; z <= hi[2] >> kShift; ++z) {
          const std::uint64_t key = geometry::VoxelKey{
              {static_cast<geometry::KeyCoord>(x), static_cast<geometry::KeyCoord>(y),
               static_cast<geometry::KeyCoord>(
                   z)}}.packed();
          if (auto it = regions_.find(key); it != regions_.end()) visitRegion(key, it->second);
        }
  }

  /// Heap bytes held (the allocator's own overhead estimated at 16 bytes per allocation).
  std::size_t memoryBytes() const {
    std::size_t n = regions_.bucket_count() * sizeof(void*) + regions_.size() * (sizeof(Node) + 16);
    if constexpr (kHasValues)
      for (const auto& [key, r] : regions_) n += r.values.capacity() * sizeof(Value) + 16;
    return n;
  }

 private:
  static constexpr int kShift = 2;  // 4 blocks per axis and region: 64 bits
  struct Region {
    std::uint64_t mask = 0;
    [[no_unique_address]] std::conditional_t<kHasValues, std::vector<Stored>, std::false_type> values{};
  };
  struct Node {  // what libstdc++'s unordered_map allocates per region
    void* next;
    std::uint64_t key;
    Region region;
  };

  static std::uint64_t regionOf(std::uint64_t id) {
    const geometry::VoxelKey b = geometry::VoxelKey::fromPacked(id);
    return geometry::VoxelKey{{static_cast<geometry::KeyCoord>(b[0] >> kShift),
                               static_cast<geometry::KeyCoord>(b[1] >> kShift),
                               static_cast<geometry::KeyCoord>(b[2] >> kShift)}}
        .packed();
  }
  static int bitOf(std::uint64_t id) {
    const geometry::VoxelKey b = geometry::VoxelKey::fromPacked(id);
    return (b[0] & 3) | (b[1] & 3) << 2 | (b[2] & 3) << 4;
  }
  static std::uint64_t idOf(std::uint64_t region, int bit) {
    const geometry::VoxelKey r = geometry::VoxelKey::fromPacked(region);
    return geometry::VoxelKey{{static_cast<geometry::KeyCoord>(r[0] << kShift | (bit & 3)),
                               static_cast<geometry::KeyCoord>(r[1] << kShift | (bit >> 2 & 3)),
                               static_cast<geometry::KeyCoord>(r[2] << kShift | (bit >> 4 & 3))}}
        .packed();
  }
  /// f for the ids of `r` in `mask`, with their values.
  template <class F>
  static void visit(std::uint64_t key, const Region& r, std::uint64_t mask, F& f) {
    mask &= r.mask;
    for (std::uint64_t m = mask; m != 0; m &= m - 1) {
      const int bit = std::countr_zero(m);
      if constexpr (kHasValues)
        f(idOf(key, bit),
          r.values[static_cast<std::size_t>(std::popcount(r.mask & ((std::uint64_t{1} << bit) - 1)))]);
      else
        f(idOf(key, bit));
    }
  }

  std::unordered_map<std::uint64_t, Region> regions_;
  std::size_t size_ = 0;
};

using BlockIdSet = BlockIdMap<void>;

}  // namespace densemap::map
