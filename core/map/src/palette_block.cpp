#include "densemap/map/palette_block.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "densemap/util/byte_codec.h"

namespace densemap::map {

namespace {
constexpr float kUnknown = std::numeric_limits<float>::quiet_NaN();
bool sameBits(float a, float b) { return std::bit_cast<std::uint32_t>(a) == std::bit_cast<std::uint32_t>(b); }
}  // namespace

PaletteBlock& PaletteBlock::operator=(const PaletteBlock& other) {
  if (this == &other) return *this;
  index_ = other.index_;
  time_s = other.time_s;
  last_scan = other.last_scan;
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

namespace {
constexpr std::uint32_t kBlockMagic = 0x31424D44;  // "DMB1"
enum Mode : std::uint8_t { kPalette = 0, kDense = 1 };
}  // namespace

std::string PaletteBlock::encode() const {
  std::string out;
  out.reserve(dense_ ? 32 + sizeof(*dense_) : 32 + palette_.size() * sizeof(float) + index_.size());
  util::ByteWriter w(out);
  w.put(kBlockMagic);
  w.put(time_s);
  w.put(last_scan);
  if (dense_) {
    w.put(static_cast<std::uint8_t>(kDense));
    w.bytes(dense_->data(), sizeof(*dense_));
  } else {
    w.put(static_cast<std::uint8_t>(kPalette));
    w.put(static_cast<std::uint16_t>(palette_.size()));
    w.bytes(palette_.data(), palette_.size() * sizeof(float));
    w.bytes(index_.data(), index_.size());
  }
  return out;
}

PaletteBlock PaletteBlock::decode(std::string_view bytes) {
  util::ByteReader r(bytes);
  if (r.get<std::uint32_t>("block magic") != kBlockMagic) r.fail("not a densemap map block");
  PaletteBlock b;
  b.time_s = r.get<double>("block time");
  if (!std::isfinite(b.time_s)) r.fail("the block's time is not finite");
  b.last_scan = r.get<std::uint64_t>("block's last scan");
  const auto mode = r.get<std::uint8_t>("block mode");
  if (mode == kDense) {
    b.dense_ = std::make_unique<std::array<float, kBlockVoxels>>();
    std::memcpy(b.dense_->data(), r.take(sizeof(*b.dense_), "block values"), sizeof(*b.dense_));
  } else if (mode == kPalette) {
    const auto n = r.get<std::uint16_t>("palette size");
    if (n < 1 || n > kMaxPalette) r.fail("palette size " + std::to_string(n) + " is not 1..256");
    b.palette_.resize(n);
    std::memcpy(b.palette_.data(), r.take(n * sizeof(float), "palette"), n * sizeof(float));
    if (!std::isnan(b.palette_[0])) r.fail("the palette's first entry is not 'unknown'");
    std::memcpy(b.index_.data(), r.take(b.index_.size(), "indices"), b.index_.size());
    for (std::uint8_t idx : b.index_)
      if (idx >= n) r.fail("an index past the palette's " + std::to_string(n) + " entries");
  } else {
    r.fail("block mode " + std::to_string(mode));
  }
  if (!r.done()) r.fail("bytes after the block");
  return b;
}

}  // namespace densemap::map
