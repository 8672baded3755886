#include "densemap/dense/kernel_layer.h"

#include "densemap/geometry/block_distance.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <sstream>

#include "densemap/util/byte_codec.h"

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
  // Blocks the kernels touch (created serially), and per block the kernels touching it, in sample order:
  // each block is then updated by one thread, so no atomics are needed and every cell sums its
  // contributions in the same order whatever the thread count (deterministic results).
  std::unordered_map<std::uint64_t, std::uint32_t> touched_index;
  std::vector<Block*> touched;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> pairs;  // (touched block, sample)
  for (std::size_t i = 0; i < n; ++i) {
    if (!valid[i]) continue;
    const auto& [lo, hi] = boxes[i];
    for (int x = lo[0] >> kShift; x <= hi[0] >> kShift; ++x)
      for (int y = lo[1] >> kShift; y <= hi[1] >> kShift; ++y)
        for (int z = lo[2] >> kShift; z <= hi[2] >> kShift; ++z) {
          const geometry::VoxelKey b{{static_cast<geometry::KeyCoord>(x), static_cast<geometry::KeyCoord>(y),
                                      static_cast<geometry::KeyCoord>(z)}};
          auto [it, inserted] =
              touched_index.try_emplace(b.packed(), static_cast<std::uint32_t>(touched.size()));
          if (inserted) {
            auto& slot = blocks_[b.packed()];
            if (!slot) slot = std::make_unique<Block>();
            touched.push_back(slot.get());
          }
          pairs.emplace_back(it->second, static_cast<std::uint32_t>(i));
        }
  }
  std::vector<std::uint32_t> offsets(touched.size() + 1, 0), order(pairs.size());
  for (const auto& [blk, i] : pairs) ++offsets[blk + 1];
  for (std::size_t t = 0; t < touched.size(); ++t) offsets[t + 1] += offsets[t];
  {
    std::vector<std::uint32_t> fill(offsets.begin(), offsets.end() - 1);
    for (const auto& [blk, i] : pairs) order[fill[blk]++] = i;
  }
  std::vector<geometry::VoxelKey> block_keys(touched.size());
  for (const auto& [id, t] : touched_index) block_keys[t] = geometry::VoxelKey::fromPacked(id);
  const float res = static_cast<float>(converter_.resolution());
  std::size_t updates = 0;
#pragma omp parallel for schedule(dynamic, 16) reduction(+ : updates)
  for (std::size_t t = 0; t < touched.size(); ++t) {
    Block& block = *touched[t];
    const int bx = block_keys[t][0], by = block_keys[t][1], bz = block_keys[t][2];
    for (std::uint32_t o = offsets[t]; o < offsets[t + 1]; ++o) {
      const std::size_t i = order[o];
      const Kernel& k = kernels[i];
      const Vec3f x = samples.points[i];
      auto& target = samples.occupied[i] != 0 ? block.alpha : block.beta;
      const auto& [lo, hi] = boxes[i];
      const int x0 = std::max<int>(lo[0], bx << kShift),
                x1 = std::min<int>(hi[0], (bx << kShift) + kSide - 1);
      const int y0 = std::max<int>(lo[1], by << kShift),
                y1 = std::min<int>(hi[1], (by << kShift) + kSide - 1);
      const int z0 = std::max<int>(lo[2], bz << kShift),
                z1 = std::min<int>(hi[2], (bz << kShift) + kSide - 1);
      // Per (x, y) column, r^2 is a quadratic in dz: C dz^2 + B dz + A. Only the cells between its roots
      // (r < 1) are visited, instead of the support's whole bounding box.
      const Eigen::Matrix3f& m = k.h_inv;
      const float c2 = m(2, 2);
      const float z_base = static_cast<float>(converter_.toCoord(static_cast<geometry::KeyCoord>(z0)));
      for (int cx = x0; cx <= x1; ++cx) {
        const float dx = static_cast<float>(converter_.toCoord(static_cast<geometry::KeyCoord>(cx))) - x.x();
        for (int cy = y0; cy <= y1; ++cy) {
          const float dy =
              static_cast<float>(converter_.toCoord(static_cast<geometry::KeyCoord>(cy))) - x.y();
          const float a = m(0, 0) * dx * dx + 2.0f * m(0, 1) * dx * dy + m(1, 1) * dy * dy;
          const float b = 2.0f * (m(0, 2) * dx + m(1, 2) * dy);
          const float disc = b * b - 4.0f * c2 * (a - 1.0f);
          if (disc <= 0.0f) continue;
          const float root = std::sqrt(disc);
          const float dz_lo = (-b - root) / (2.0f * c2), dz_hi = (-b + root) / (2.0f * c2);
          const int za = std::max(z0, z0 + static_cast<int>(std::ceil((dz_lo + x.z() - z_base) / res)));
          const int zb = std::min(z1, z0 + static_cast<int>(std::floor((dz_hi + x.z() - z_base) / res)));
          const int row = ((cx & (kSide - 1)) << (2 * kShift)) | ((cy & (kSide - 1)) << kShift);
          for (int cz = za; cz <= zb; ++cz) {
            const float dz = z_base + static_cast<float>(cz - z0) * res - x.z();
            const float r2 = a + dz * (b + c2 * dz);
            if (r2 >= 1.0f) continue;
            target[static_cast<std::size_t>(row | (cz & (kSide - 1)))] +=
                k.weight * sparseKernel(std::sqrt(std::max(r2, 0.0f)));
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

std::vector<std::uint64_t> KernelLayer::blocksFartherThan(std::span<const Vec3f> centres,
                                                          double radius) const {
  std::vector<std::uint64_t> ids;
  for (const auto& [id, b] : blocks_) {
    const Vec3f c = converter_.toCoord(geometry::blockCentreKey(geometry::VoxelKey::fromPacked(id), kShift));
    if (geometry::fartherThanAll(c, centres, radius)) ids.push_back(id);
  }
  return ids;
}

std::size_t KernelLayer::dropBlocks(const std::vector<std::uint64_t>& ids) {
  std::size_t n = 0;
  for (std::uint64_t id : ids) n += blocks_.erase(id);
  return n;
}

std::size_t KernelLayer::memoryBytes() const { return blocks_.size() * (sizeof(Block) + 32); }

}  // namespace densemap::dense

namespace densemap::dense {

namespace {
constexpr std::uint32_t kStateMagic = 0x4C4B4D44;  // "DMKL"
constexpr std::uint32_t kStateVersion = 1;
}  // namespace

std::string KernelLayer::saveState() const {
  std::string out;
  util::ByteWriter w(out);
  w.put(kStateMagic);
  w.put(kStateVersion);
  w.string(name());
  w.put(options_.resolution);
  std::ostringstream rng;
  rng << rng_;  // the standard's text form of the engine's state, exact
  w.string(rng.str());
  // Sorted by key, so equal layers give equal bytes.
  std::vector<std::uint64_t> keys;
  keys.reserve(blocks_.size());
  for (const auto& [k, b] : blocks_) keys.push_back(k);
  std::sort(keys.begin(), keys.end());
  w.put(static_cast<std::uint64_t>(keys.size()));
  for (std::uint64_t k : keys) {
    const Block& b = *blocks_.at(k);
    w.put(k);
    w.bytes(b.alpha.data(), sizeof b.alpha);
    w.bytes(b.beta.data(), sizeof b.beta);
  }
  return out;
}

void KernelLayer::restoreState(std::string_view bytes) {
  util::ByteReader r(bytes);
  if (r.get<std::uint32_t>("dense state magic") != kStateMagic) r.fail("not a dense layer state");
  if (const auto v = r.get<std::uint32_t>("dense state version"); v != kStateVersion)
    r.fail("dense layer state version " + std::to_string(v) + " is not " + std::to_string(kStateVersion));
  if (const std::string kind = r.string("dense layer kind", 64); kind != name())
    r.fail("the state is of a " + kind + " layer, this layer is " + name());
  if (const auto res = r.get<double>("dense resolution"); res != options_.resolution)
    r.fail("the state has resolution " + std::to_string(res) + " m, this layer " +
           std::to_string(options_.resolution) + " m");
  std::mt19937_64 rng;
  {
    std::istringstream in(r.string("dense generator state", 1 << 16));
    in >> rng;
    if (!in) r.fail("the dense layer's generator state does not parse");
  }
  constexpr std::size_t kBlockBytes = sizeof(std::uint64_t) + 2 * sizeof(Block::alpha);
  const std::uint64_t n = r.count("dense block count", kBlockBytes);
  std::unordered_map<std::uint64_t, std::unique_ptr<Block>> blocks;
  blocks.reserve(n);
  for (std::uint64_t i = 0; i < n; ++i) {
    const auto key = r.get<std::uint64_t>("dense block key");
    auto b = std::make_unique<Block>();
    std::memcpy(b->alpha.data(), r.take(sizeof b->alpha, "dense block alpha"), sizeof b->alpha);
    std::memcpy(b->beta.data(), r.take(sizeof b->beta, "dense block beta"), sizeof b->beta);
    if (!blocks.emplace(key, std::move(b)).second) r.fail("dense block " + std::to_string(key) + " twice");
  }
  if (!r.done()) r.fail(std::to_string(r.remaining()) + " bytes after the dense layer state");
  blocks_ = std::move(blocks);
  rng_ = rng;
}

}  // namespace densemap::dense
