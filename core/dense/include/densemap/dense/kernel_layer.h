// A dense occupancy layer built by kernel inference (Ch. 3): every occupancy sample spreads its label
// to the cells its kernel covers, each cell accumulating alpha (occupied) and beta (free) evidence
// (Eq. 3.8, 3.9); a query returns alpha / (alpha + beta) (Eq. 3.4). Subclasses choose each sample's
// bandwidth: AKIMap adapts it per sample, the BGK baseline uses one isotropic length scale.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <memory>
#include <optional>
#include <random>
#include <span>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>

#include "densemap/dense/occupancy_samples.h"
#include "densemap/geometry/voxel_key.h"

namespace densemap::dense {

/// Eq. 3.5: the sparse kernel of Melkumyan and Ramos, 1 at r = 0, 0 from r = 1 on (exact evaluation).
inline float sparseKernelExact(float r) {
  constexpr float kTwoPi = 6.28318530717958647692f;
  if (r >= 1.0f) return 0.0f;
  return (2.0f + std::cos(kTwoPi * r)) / 3.0f * (1.0f - r) + std::sin(kTwoPi * r) / kTwoPi;
}

/// Eq. 3.5 from a table with linear interpolation (error below 1e-6): the bandwidth search and the cell
/// updates evaluate the kernel millions of times per scan, and a sine and a cosine each time dominated.
class SparseKernelTable {
 public:
  static constexpr int kSize = 4096;
  SparseKernelTable() {
    for (int i = 0; i <= kSize; ++i)
      values_[static_cast<std::size_t>(i)] = sparseKernelExact(static_cast<float>(i) / kSize);
  }
  float operator()(float r) const {
    if (!(r < 1.0f)) return 0.0f;
    const float x = std::max(r, 0.0f) * kSize;
    const int i = static_cast<int>(x);
    const float f = x - static_cast<float>(i);
    return values_[static_cast<std::size_t>(i)] * (1.0f - f) + values_[static_cast<std::size_t>(i) + 1] * f;
  }

 private:
  std::array<float, kSize + 1> values_{};
};

inline const SparseKernelTable kSparseKernelTable;

inline float sparseKernel(float r) { return kSparseKernelTable(r); }

/// One sample's kernel: its shape (inverse bandwidth) and signal weight.
struct Kernel {
  Eigen::Matrix3f h_inv = Eigen::Matrix3f::Identity();    ///< H^-1: r^2 = d^T H^-1 d
  Eigen::Vector3f half_extent = Eigen::Vector3f::Zero();  ///< sqrt(diag(H)): the support's bounding box
  float weight = 0.0f;                                    ///< multiplies k(r) (|H|^-1/2 for AKIMap)
};

struct KernelLayerOptions {
  double resolution = 0.1;  ///< cell size (metres)
  SamplingOptions sampling{};
  /// Beta prior of every cell (Eq. 3.2, 3.3). BGKOctoMap's default is 0.001 for both.
  float prior_alpha = 0.001f;
  float prior_beta = 0.001f;
  /// A cell whose accumulated kernel evidence (alpha + beta without the prior) is below this reads as
  /// unknown. In the kernels' weight units: BGK adds sf2 (1) at a sample, AKIMap |H|^-1/2 (metres^-3,
  /// 10^1-10^4 at these scales), so for AKIMap this only marks cells its kernels barely reach.
  float unknown_evidence = 0.001f;
  std::uint64_t seed = 1;  ///< free-sample generator
};

struct LayerStats {
  std::size_t samples = 0, occupied_samples = 0;
  std::size_t cell_updates = 0;  ///< kernel evaluations with r < 1
  double sampling_ms = 0, bandwidth_ms = 0, accumulate_ms = 0;
  double totalMs() const { return sampling_ms + bandwidth_ms + accumulate_ms; }
};

class KernelLayer {
 public:
  explicit KernelLayer(const KernelLayerOptions& options);
  virtual ~KernelLayer() = default;

  virtual std::string name() const = 0;

  /// Integrates one scan (world-frame points, sensor origin) incrementally: prepare() then commit().
  LayerStats insert(const std::vector<Vec3f>& points, const Vec3f& origin);

  /// A scan's samples and kernels, computed without changing what queries see.
  struct Prepared {
    SampleSet samples;
    std::vector<Kernel> kernels;
    LayerStats stats;
  };
  /// The read-only part of insert() (for the writer thread; it does not touch the cells).
  Prepared prepare(const std::vector<Vec3f>& points, const Vec3f& origin);
  /// Adds a prepared scan's kernels to the cells (the part readers must not overlap).
  void commit(Prepared& prepared);

  /// P(occupied) of the cell holding p, or nullopt when the layer has too little evidence there.
  std::optional<float> probability(const Vec3f& p) const;
  /// Accumulated (alpha, beta) without the prior; zero for cells never touched.
  std::array<float, 2> evidence(const geometry::VoxelKey& key) const;

  std::size_t blockCount() const { return blocks_.size(); }
  /// The blocks whose centre is farther than `radius` from every one of `centres` (a rolling window over
  /// the layer; the service drops them).
  std::vector<std::uint64_t> blocksFartherThan(std::span<const Vec3f> centres, double radius) const;
  /// Forgets these blocks (their cells go back to the prior). Returns how many there were.
  std::size_t dropBlocks(const std::vector<std::uint64_t>& ids);
  std::size_t memoryBytes() const;
  const KernelLayerOptions& options() const { return options_; }
  const geometry::KeyConverter& converter() const { return converter_; }
  void clear() { blocks_.clear(); }

  /// The layer's whole state (every block's evidence and the free-sample generator's state), for
  /// snapshots: a layer restored from it continues bit for bit as this one would.
  std::string saveState() const;
  /// Replaces this layer's state with saveState()'s bytes. Throws util::FormatError (damaged bytes, or
  /// state of another kind of layer or resolution) and then leaves the layer as it was.
  void restoreState(std::string_view bytes);

 protected:
  /// One kernel per sample. `max_range` is the longest ray of the scan (sets search radii).
  virtual void bandwidths(const SampleSet& samples, double max_range, std::vector<Kernel>& out) = 0;

  KernelLayerOptions options_;
  geometry::KeyConverter converter_;

 private:
  static constexpr int kShift = 3;  // 8^3 cells per block
  static constexpr int kSide = 1 << kShift;
  struct Block {
    std::array<float, kSide * kSide * kSide> alpha{}, beta{};
  };
  void accumulate(const SampleSet& samples, const std::vector<Kernel>& kernels, LayerStats& stats);

  std::unordered_map<std::uint64_t, std::unique_ptr<Block>> blocks_;
  std::mt19937_64 rng_;
};

}  // namespace densemap::dense
