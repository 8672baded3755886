// One 16^3 block of the grid's log-odds, stored compactly: a byte per voxel indexing the block's table of
// distinct values (its palette). A batch update moves a cell between few values (l_free and l_occ steps,
// clamped), so a block rarely holds more than a few dozen at once, and the byte per voxel is a quarter of
// a float. Values are kept bit for bit, so the map stays exact. A block whose voxels need more than 256
// distinct values at once (counting semantics can) falls back to one float per voxel.
#pragma once

#include <array>
#include <bit>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "densemap/map/scan_evidence.h"

namespace densemap::map {

class PaletteBlock {
 public:
  static constexpr std::size_t kMaxPalette = 256;

  PaletteBlock() { reset(); }
  PaletteBlock(const PaletteBlock& other) { *this = other; }
  PaletteBlock& operator=(const PaletteBlock& other);
  PaletteBlock(PaletteBlock&&) = default;
  PaletteBlock& operator=(PaletteBlock&&) = default;

  /// Every voxel unknown (NaN), palette {NaN}; keeps the palette's capacity (blocks are reused).
  void reset();

  /// Log-odds of voxel i (NaN: never observed).
  float get(int i) const {
    const auto u = static_cast<std::size_t>(i);
    return dense_ ? (*dense_)[u] : palette_[index_[u]];
  }
  /// Where voxel i's palette index is (or its float, when dense): the first load of get(), to prefetch.
  const void* indexAddress(int i) const {
    const auto u = static_cast<std::size_t>(i);
    return dense_ ? static_cast<const void*>(&(*dense_)[u]) : static_cast<const void*>(&index_[u]);
  }
  /// Where voxel i's value is: the second load of get() (reads the index), to prefetch. Valid until the
  /// block changes.
  const float* valueAddress(int i) const {
    const auto u = static_cast<std::size_t>(i);
    return dense_ ? &(*dense_)[u] : &palette_[index_[u]];
  }

  /// Sets voxel i. Returns false when the palette's numbering changed (it was full and was compacted, or
  /// the block went dense), so indices a caller remembered are stale.
  bool set(int i, float value);

  bool dense() const { return dense_ != nullptr; }
  /// Palette mode only: voxel i's palette index, and the value an index stands for.
  std::uint8_t indexOf(int i) const { return index_[static_cast<std::size_t>(i)]; }
  float paletteValue(std::uint8_t idx) const { return palette_[idx]; }
  /// Palette mode only: points voxel i at an index the palette already has.
  void setIndex(int i, std::uint8_t idx) { index_[static_cast<std::size_t>(i)] = idx; }
  std::size_t paletteSize() const { return palette_.size(); }

  /// Replaces every stored value v by f(v) (decay): O(palette) in palette mode, which is why decay keeps
  /// its time per block. f(NaN) must be NaN.
  template <class F>
  void transformValues(F&& f) {
    if (dense_) {
      for (float& v : *dense_) v = f(v);
    } else {
      for (float& v : palette_) v = f(v);
    }
  }

  /// Map time (s) this block's values are current at: decay is applied up to here (decay.h).
  double time_s = 0.0;
  /// The map's scan count when a scan last changed this block (the least recently updated leave memory
  /// first under a memory cap).
  std::uint64_t last_scan = 0;

  std::size_t knownCount() const;
  bool anyKnown() const;
  /// Bytes this block owns (the byte indices or floats, and the palette's capacity).
  std::size_t memoryBytes() const;

  /// The block as bytes (a block leaving memory, the rolling window): its time, then its palette
  /// and indices, or its floats. Values bit for bit.
  std::string encode() const;
  /// Throws util::FormatError naming what is wrong (a bad size, mode or index, a non-finite time).
  static PaletteBlock decode(std::string_view bytes);

 private:
  /// Drops palette entries no voxel uses; returns false when all 256 are in use.
  bool compact();
  void makeDense();

  std::array<std::uint8_t, kBlockVoxels> index_;
  std::vector<float> palette_;                              // [0] is NaN
  std::unique_ptr<std::array<float, kBlockVoxels>> dense_;  // set: one float per voxel, palette unused
};

}  // namespace densemap::map
