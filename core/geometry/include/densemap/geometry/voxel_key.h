// Discrete voxel addresses shared by every backend. The key space is OctoMap's (16 bits per axis,
// centred at 2^15) so grid and octree maps, and OctoMap itself, agree on which voxel a point is in.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <functional>

#include <Eigen/Core>

namespace densemap::geometry {

using Vec3f = Eigen::Vector3f;
using KeyCoord = std::uint16_t;

/// Bits per key axis: OctoMap's tree depth.
inline constexpr unsigned kKeyDepth = 16;
/// Half the key range: the key of coordinate 0 (OctoMap's tree_max_val for depth 16).
inline constexpr int kKeyCenter = 32768;

struct VoxelKey {
  std::array<KeyCoord, 3> k{0, 0, 0};

  constexpr KeyCoord operator[](int i) const { return k[static_cast<std::size_t>(i)]; }
  constexpr KeyCoord& operator[](int i) { return k[static_cast<std::size_t>(i)]; }
  // By component: the defaulted == compiles to a call to memcmp, which the ray walks made once per ray.
  friend constexpr bool operator==(const VoxelKey& a, const VoxelKey& b) {
    return a.k[0] == b.k[0] && a.k[1] == b.k[1] && a.k[2] == b.k[2];
  }

  /// 48-bit packed form, usable as a sort or hash key.
  constexpr std::uint64_t packed() const {
    return (std::uint64_t{k[0]} << 32) | (std::uint64_t{k[1]} << 16) | std::uint64_t{k[2]};
  }
  static constexpr VoxelKey fromPacked(std::uint64_t p) {
    return VoxelKey{
        {static_cast<KeyCoord>(p >> 32), static_cast<KeyCoord>(p >> 16), static_cast<KeyCoord>(p)}};
  }
};

struct VoxelKeyHash {
  std::size_t operator()(const VoxelKey& key) const noexcept {
    // Spread the three 16-bit coordinates with large odd multipliers (cheap, good enough for
    // unordered containers of voxel keys).
    return static_cast<std::size_t>(key.k[0]) * 83492791ULL ^
           static_cast<std::size_t>(key.k[1]) * 19349663ULL ^
           static_cast<std::size_t>(key.k[2]) * 73856093ULL;
  }
};

/// Converts between metric coordinates and keys exactly as OctoMap's OcTreeBaseImpl does
/// (coordToKeyChecked / keyToCoord), so results can be compared with OctoMap bit for bit.
class KeyConverter {
 public:
  explicit KeyConverter(double resolution) : resolution_(resolution), resolution_factor_(1.0 / resolution) {}

  double resolution() const { return resolution_; }

  /// False when the coordinate lies outside the 16-bit key range.
  bool toKey(double coordinate, KeyCoord& key) const {
    // Range-checked in double before the conversion: OctoMap casts first, which is undefined behaviour for
    // coordinates beyond int (found by fuzz_dds_scan); in range, the key is the same.
    const double scaled = std::floor(resolution_factor_ * coordinate) + kKeyCenter;
    if (scaled >= 0.0 && scaled < 2.0 * kKeyCenter) {
      key = static_cast<KeyCoord>(scaled);
      return true;
    }
    return false;  // out of range, or NaN
  }

  bool toKey(const Vec3f& p, VoxelKey& key) const {
    return toKey(p.x(), key.k[0]) && toKey(p.y(), key.k[1]) && toKey(p.z(), key.k[2]);
  }

  /// Centre of the voxel along one axis.
  double toCoord(KeyCoord key) const {
    return (static_cast<double>(static_cast<int>(key) - kKeyCenter) + 0.5) * resolution_;
  }

  Vec3f toCoord(const VoxelKey& key) const {
    return {static_cast<float>(toCoord(key[0])), static_cast<float>(toCoord(key[1])),
            static_cast<float>(toCoord(key[2]))};
  }

  /// Lower corner of the voxel (the grid plane at its low side).
  double lowerBound(KeyCoord key) const {
    return static_cast<double>(static_cast<int>(key) - kKeyCenter) * resolution_;
  }

 private:
  double resolution_;
  double resolution_factor_;
};

}  // namespace densemap::geometry

template <>
struct std::hash<densemap::geometry::VoxelKey> : densemap::geometry::VoxelKeyHash {};
