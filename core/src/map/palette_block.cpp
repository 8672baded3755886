#include "densemap/map/palette_block.h"

#include <algorithm>
#include <cmath>

namespace densemap::map {

namespace {
constexpr float kUnknown = std::numeric_limits<float>::quiet_NaN();
bool sameBits(float a, float b) { return std::bit_cast<std::uint32_t>(a) == std::bit_cast<std::uint32_t>(b); }
}  // namespace

PaletteBlock& PaletteBlock::operator=(const PaletteBlock& other) {
  if (this == &other) return *this;
  index_ = other.index_;
  time_s = other.time_s;
  palette_ =
      other.palette_;  // reuses this block's capacity: the staging copies of every scan do not allocate
  if (other.dense_) {
    if (!dense_) dense_ = std::make_unique<std::array<float, kBlockVoxels>>();
    *dense_ = *other.dense_;
  } else {
    dense_.reset();
  }
  return *this;
}

void PaletteBlock::reset() {
  index_.fill(0);
  palette_.assign(1, kUnknown);
  dense_.reset();
}

bool PaletteBlock::set(int i, float value) {
  const auto u = static_cast<std::size_t>(i);
  if (dense_) {
    (*dense_)[u] = value;
    return true;
  }
  for (std::size_t k = 0; k < palette_.size(); ++k) {
    if (sameBits(palette_[k], value)) {
      index_[u] = static_cast<std::uint8_t>(k);
      return true;
    }
  }
  if (palette_.size() < kMaxPalette) {
    palette_.push_back(value);
    index_[u] = static_cast<std::uint8_t>(palette_.size() - 1);
    return true;
  }
  index_[u] = 0;  // its old value may be the one entry that compaction can drop
  if (compact()) {
    palette_.push_back(value);
    index_[u] = static_cast<std::uint8_t>(palette_.size() - 1);
  } else {
    makeDense();
    (*dense_)[u] = value;
  }
  return false;
}

bool PaletteBlock::compact() {
  std::array<std::uint32_t, kMaxPalette> uses{};
  for (std::uint8_t idx : index_) ++uses[idx];
  // Keep entry 0 (unknown) and one entry per distinct value in use (decay can make two entries equal).
  std::array<std::uint8_t, kMaxPalette> remap{};
  std::vector<float> kept{kUnknown};
  for (std::size_t k = 1; k < palette_.size(); ++k) {
    if (uses[k] == 0) continue;
    const float v = palette_[k];
    const auto same = std::find_if(kept.begin(), kept.end(), [&](float x) { return sameBits(x, v); });
    if (same != kept.end()) {
      remap[k] = static_cast<std::uint8_t>(same - kept.begin());
    } else {
      remap[k] = static_cast<std::uint8_t>(kept.size());
      kept.push_back(v);
    }
  }
  if (kept.size() >= kMaxPalette) return false;
  for (std::uint8_t& idx : index_) idx = remap[idx];
  palette_.swap(kept);
  return true;
}

void PaletteBlock::makeDense() {
  auto values = std::make_unique<std::array<float, kBlockVoxels>>();
  for (std::size_t u = 0; u < index_.size(); ++u) (*values)[u] = palette_[index_[u]];
  dense_ = std::move(values);
  palette_.assign(1, kUnknown);
  palette_.shrink_to_fit();
}

std::size_t PaletteBlock::knownCount() const {
  std::size_t n = 0;
  if (dense_) {
    for (float v : *dense_) n += std::isnan(v) ? 0 : 1;
    return n;
  }
  std::array<std::uint32_t, kMaxPalette> uses{};
  for (std::uint8_t idx : index_) ++uses[idx];
  for (std::size_t k = 0; k < palette_.size(); ++k) n += std::isnan(palette_[k]) ? 0 : uses[k];
  return n;
}

bool PaletteBlock::anyKnown() const {
  if (dense_) return knownCount() != 0;
  std::array<bool, kMaxPalette> known{};
  bool any = false;
  for (std::size_t k = 0; k < palette_.size(); ++k) any |= known[k] = !std::isnan(palette_[k]);
  if (!any) return false;
  for (std::uint8_t idx : index_)
    if (known[idx]) return true;
  return false;
}

std::size_t PaletteBlock::memoryBytes() const {
  return sizeof(PaletteBlock) + palette_.capacity() * sizeof(float) + (dense_ ? sizeof(*dense_) : 0);
}

}  // namespace densemap::map
