#include "densemap/dense/kernel_layer.h"

#include <atomic>
#include <chrono>
#include <cmath>

namespace densemap::dense {

namespace {
using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}
}  // namespace

KernelLayer::KernelLayer(const KernelLayerOptions& options)
    : options_(options), converter_(options.resolution), rng_(options.seed) {
  options_.sampling.resolution = options.resolution;
}

LayerStats KernelLayer::insert(const std::vector<Vec3f>& points, const Vec3f& origin) {
  Prepared p = prepare(points, origin);
  commit(p);
  return p.stats;
}

KernelLayer::Prepared KernelLayer::prepare(const std::vector<Vec3f>& points, const Vec3f& origin) {
  Prepared p;
  auto t = Clock::now();
  p.samples = sampleScan(points, origin, options_.sampling, rng_);
  p.stats.sampling_ms = msSince(t);
  float longest = 0.0f;
  for (float r : p.samples.range) longest = std::max(longest, r);
  const double max_range = options_.sampling.max_range > 0 ? options_.sampling.max_range : longest;
  p.stats.samples = p.samples.size();
  p.stats.occupied_samples = p.samples.occupiedCount();
  t = Clock::now();
  p.kernels.resize(p.samples.size());
  bandwidths(p.samples, max_range, p.kernels);
  p.stats.bandwidth_ms = msSince(t);
  return p;
}

void KernelLayer::commit(Prepared& p) {
  const auto t = Clock::now();
  accumulate(p.samples, p.kernels, p.stats);
  p.stats.accumulate_ms = msSince(t);
}

LayerStats KernelLayer::insertSamples(const SampleSet& samples, double max_range) {
  LayerStats st;
  st.samples = samples.size();
  st.occupied_samples = samples.occupiedCount();
  auto t = Clock::now();
  kernels_.resize(samples.size());
  bandwidths(samples, max_range, kernels_);
  st.bandwidth_ms = msSince(t);
  t = Clock::now();
  accumulate(samples, kernels_, st);
  st.accumulate_ms = msSince(t);
  return st;
}

void KernelLayer::accumulate(const SampleSet& samples, const std::vector<Kernel>& kernels,
                             LayerStats& stats) {
  const std::size_t n = samples.size();
  // Key boxes of the kernels' supports, and the blocks they touch (allocated serially).
  std::vector<std::array<geometry::VoxelKey, 2>> boxes(n);
  std::vector<std::uint8_t> valid(n, 0);
#pragma omp parallel for schedule(static)
  for (std::size_t i = 0; i < n; ++i) {
    const Kernel& k = kernels[i];
    if (!(k.weight > 0.0f)) continue;
    const Vec3f lo = samples.points[i] - k.half_extent, hi = samples.points[i] + k.half_extent;
    valid[i] = converter_.toKey(lo, boxes[i][0]) && converter_.toKey(hi, boxes[i][1]);
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (!valid[i]) continue;
    const auto& [lo, hi] = boxes[i];
    for (int x = lo[0] >> kShift; x <= hi[0] >> kShift; ++x)
      for (int y = lo[1] >> kShift; y <= hi[1] >> kShift; ++y)
        for (int z = lo[2] >> kShift; z <= hi[2] >> kShift; ++z) {
          const geometry::VoxelKey b{{static_cast<geometry::KeyCoord>(x), static_cast<geometry::KeyCoord>(y),
                                      static_cast<geometry::KeyCoord>(z)}};
          auto& slot = blocks_[b.packed()];
          if (!slot) slot = std::make_unique<Block>();
        }
  }
  std::size_t updates = 0;
#pragma omp parallel for schedule(dynamic, 64) reduction(+ : updates)
  for (std::size_t i = 0; i < n; ++i) {
    if (!valid[i]) continue;
    const Kernel& k = kernels[i];
    const Vec3f x = samples.points[i];
    const bool occ = samples.occupied[i] != 0;
    const auto& [lo, hi] = boxes[i];
    for (int bx = lo[0] >> kShift; bx <= hi[0] >> kShift; ++bx)
      for (int by = lo[1] >> kShift; by <= hi[1] >> kShift; ++by)
        for (int bz = lo[2] >> kShift; bz <= hi[2] >> kShift; ++bz) {
          const geometry::VoxelKey b{{static_cast<geometry::KeyCoord>(bx),
                                      static_cast<geometry::KeyCoord>(by),
                                      static_cast<geometry::KeyCoord>(bz)}};
          Block& block = *blocks_.find(b.packed())->second;
          auto& target = occ ? block.alpha : block.beta;
          const int x0 = std::max<int>(lo[0], bx << kShift),
                    x1 = std::min<int>(hi[0], (bx << kShift) + kSide - 1);
          const int y0 = std::max<int>(lo[1], by << kShift),
                    y1 = std::min<int>(hi[1], (by << kShift) + kSide - 1);
          const int z0 = std::max<int>(lo[2], bz << kShift),
                    z1 = std::min<int>(hi[2], (bz << kShift) + kSide - 1);
          for (int cx = x0; cx <= x1; ++cx) {
            const float dx =
                static_cast<float>(converter_.toCoord(static_cast<geometry::KeyCoord>(cx))) - x.x();
            for (int cy = y0; cy <= y1; ++cy) {
              const float dy =
                  static_cast<float>(converter_.toCoord(static_cast<geometry::KeyCoord>(cy))) - x.y();
              for (int cz = z0; cz <= z1; ++cz) {
                const float dz =
                    static_cast<float>(converter_.toCoord(static_cast<geometry::KeyCoord>(cz))) - x.z();
                const Eigen::Vector3f d(dx, dy, dz);
                const float r2 = d.dot(k.h_inv * d);
                if (r2 >= 1.0f) continue;
                const float w = k.weight * sparseKernel(std::sqrt(r2));
                const int idx = (((cx & (kSide - 1)) << (2 * kShift)) | ((cy & (kSide - 1)) << kShift) |
                                 (cz & (kSide - 1)));
                std::atomic_ref<float>(target[static_cast<std::size_t>(idx)])
                    .fetch_add(w, std::memory_order_relaxed);
                ++updates;
              }
            }
          }
        }
  }
  stats.cell_updates = updates;
}

std::array<float, 2> KernelLayer::evidence(const geometry::VoxelKey& key) const {
  const geometry::VoxelKey b{{static_cast<geometry::KeyCoord>(key[0] >> kShift),
                              static_cast<geometry::KeyCoord>(key[1] >> kShift),
                              static_cast<geometry::KeyCoord>(key[2] >> kShift)}};
  auto it = blocks_.find(b.packed());
  if (it == blocks_.end()) return {0.0f, 0.0f};
  const int idx = (((key[0] & (kSide - 1)) << (2 * kShift)) | ((key[1] & (kSide - 1)) << kShift) |
                   (key[2] & (kSide - 1)));
  return {it->second->alpha[static_cast<std::size_t>(idx)], it->second->beta[static_cast<std::size_t>(idx)]};
}

std::optional<float> KernelLayer::probability(const Vec3f& p) const {
  geometry::VoxelKey key;
  if (!p.allFinite() || !converter_.toKey(p, key)) return std::nullopt;
  const auto [a, b] = evidence(key);
  if (a + b < options_.unknown_evidence) return std::nullopt;
  const float alpha = a + options_.prior_alpha, beta = b + options_.prior_beta;
  return alpha / (alpha + beta);  // Eq. 3.4
}

std::size_t KernelLayer::memoryBytes() const { return blocks_.size() * (sizeof(Block) + 32); }

}  // namespace densemap::dense
