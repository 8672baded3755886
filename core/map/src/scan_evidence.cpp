#include "densemap/map/scan_evidence.h"

#include <algorithm>
#include <new>
#include <stdexcept>
#include <type_traits>

namespace densemap::map {

static_assert(std::is_trivially_default_constructible_v<BitPlane>);

ScanEvidence::Chunk::Chunk(std::size_t index)
    : memory(sizeof(EvidenceBlock) * kChunkBlocks),
      blocks(std::launder(reinterpret_cast<EvidenceBlock*>(memory.data()))) {
  // The mapping is zeroed, which is an empty block: construct the objects in place without touching more.
  for (std::size_t i = 0; i < kChunkBlocks; ++i) {
    EvidenceBlock* b = ::new (static_cast<void*>(blocks + i)) EvidenceBlock();
    b->id = static_cast<std::uint32_t>(index * kChunkBlocks + i);
  }
}

ScanEvidence::ScanEvidence()
    : chunks_(kMaxChunks), chunk_ptrs_(std::make_unique<std::atomic<Chunk*>[]>(kMaxChunks)) {
  for (std::size_t i = 0; i < kMaxChunks; ++i) chunk_ptrs_[i].store(nullptr, std::memory_order_relaxed);
}

ScanEvidence::~ScanEvidence() = default;

void ScanEvidence::reset(const VoxelKey& min_key, const VoxelKey& max_key, bool counting) {
  // Clear the blocks the previous scan used (they are reused, so steady state allocates nothing); counters
  // are only touched when the previous scan used them.
  const std::size_t used = std::min(used_.load(), capacity());
  const bool counters = counters_dirty_, regions = regions_dirty_;
#pragma omp parallel for schedule(static)
  for (std::size_t i = 0; i < used; ++i) {
    Chunk* c = chunk_ptrs_[i / kChunkBlocks].load(std::memory_order_relaxed);
    c->blocks[i % kChunkBlocks].clear(counters, regions);
  }
  regions_dirty_ = false;
  counting_ = counting;
  counters_dirty_ = counting;
  used_.store(0);
  overflow_.clear();
  std::size_t size = 1;
  for (int i = 0; i < 3; ++i) {
    lo_[i] = min_key[i] >> kBlockShift;
    // An empty box (min above max) holds nothing: every cell goes to the overflow map.
    dims_[i] = std::max((max_key[i] >> kBlockShift) - lo_[i] + 1, 0);
    size *= static_cast<std::size_t>(dims_[i]);
  }
  if (size > directory_capacity_) {
    directory_ = std::make_unique<std::atomic<EvidenceBlock*>[]>(size);
    directory_capacity_ = size;
  }
  directory_size_ = size;
  for (std::size_t i = 0; i < size; ++i) directory_[i].store(nullptr, std::memory_order_relaxed);
}

bool ScanEvidence::insideBox(const VoxelKey& key) const {
  for (int i = 0; i < 3; ++i) {
    const int b = (key[i] >> kBlockShift) - lo_[i];
    if (b < 0 || b >= dims_[i]) return false;
  }
  return true;
}

EvidenceBlock* ScanEvidence::allocate() {
  const std::size_t i = used_.fetch_add(1);
  if (i >= capacity()) throw std::length_error("ScanEvidence: scan touches too many blocks");
  const std::size_t c = i / kChunkBlocks;
  Chunk* chunk = chunk_ptrs_[c].load(std::memory_order_acquire);
  if (chunk == nullptr) {
    std::lock_guard<std::mutex> lock(chunk_mutex_);
    chunk = chunk_ptrs_[c].load(std::memory_order_acquire);
    if (chunk == nullptr) {
      chunks_[c] = std::make_unique<Chunk>(c);
      chunk = chunks_[c].get();
      chunk_ptrs_[c].store(chunk, std::memory_order_release);
    }
  }
  EvidenceBlock* b = &chunk->blocks[i % kChunkBlocks];
  if (counting_ && b->counters == nullptr) {
    // First counting use of this chunk: give all its blocks zeroed counters (under the chunk lock).
    std::lock_guard<std::mutex> lock(chunk_mutex_);
    if (b->counters == nullptr) {
      chunks_[c]->counters = std::make_unique<std::array<EvidenceBlock::Counters, kChunkBlocks>>();
      for (std::size_t k = 0; k < kChunkBlocks; ++k) {
        auto& cnt = (*chunks_[c]->counters)[k];
        cnt.n_free.fill(0);
        cnt.n_hit.fill(0);
        chunks_[c]->blocks[k].counters = &cnt;
      }
    }
  }
  return b;
}

EvidenceBlock* ScanEvidence::block(const VoxelKey& key) {
  auto* s = slot(key);
  if (s == nullptr) return nullptr;
  EvidenceBlock* b = s->load(std::memory_order_acquire);
  if (b != nullptr) return b;
  EvidenceBlock* fresh = allocate();
  constexpr geometry::KeyCoord mask = static_cast<geometry::KeyCoord>(~(kBlockSide - 1));
  fresh->base = VoxelKey{{static_cast<geometry::KeyCoord>(key[0] & mask),
                          static_cast<geometry::KeyCoord>(key[1] & mask),
                          static_cast<geometry::KeyCoord>(key[2] & mask)}};
  EvidenceBlock* expected = nullptr;
  if (s->compare_exchange_strong(expected, fresh, std::memory_order_acq_rel)) {
    fresh->installed = true;
    return fresh;
  }
  return expected;  // another thread installed it first; `fresh` stays unused and empty
}

void ScanEvidence::addOverflow(const VoxelKey& key, std::uint32_t nf, std::uint32_t nh, bool saturate) {
  std::lock_guard<std::mutex> lock(overflow_mutex_);
  auto& c = overflow_[key];
  if (saturate) {
    c.first = std::max(c.first, nf);
    c.second = std::max(c.second, nh);
  } else {
    c.first += nf;
    c.second += nh;
  }
}

void ScanEvidence::addFree(const VoxelKey& key, std::uint32_t w) {
  if (EvidenceBlock* b = block(key)) {
    const auto i = static_cast<std::size_t>(voxelIndexInBlock(key));
    std::atomic_ref<std::uint32_t>(b->counters->n_free[i]).fetch_add(w, std::memory_order_relaxed);
    b->free.setAtomic(static_cast<int>(i));
  } else {
    addOverflow(key, w, 0, false);
  }
}

void ScanEvidence::addHit(const VoxelKey& key, std::uint32_t w) {
  if (EvidenceBlock* b = block(key)) {
    const auto i = static_cast<std::size_t>(voxelIndexInBlock(key));
    std::atomic_ref<std::uint32_t>(b->counters->n_hit[i]).fetch_add(w, std::memory_order_relaxed);
    b->hit.setAtomic(static_cast<int>(i));
  } else {
    addOverflow(key, 0, w, false);
  }
}

void ScanEvidence::markFree(const VoxelKey& key) {
  if (EvidenceBlock* b = block(key)) {
    b->free.setAtomic(voxelIndexInBlock(key));
  } else {
    addOverflow(key, 1, 0, true);
  }
}

void ScanEvidence::markHit(const VoxelKey& key) {
  if (EvidenceBlock* b = block(key)) {
    b->hit.setAtomic(voxelIndexInBlock(key));
  } else {
    addOverflow(key, 0, 1, true);
  }
}

void ScanEvidence::resolveOccupiedWins() {
  const std::size_t n = blockCount();
#pragma omp parallel for schedule(static)
  for (std::size_t i = 0; i < n; ++i) {
    EvidenceBlock& b =
        chunk_ptrs_[i / kChunkBlocks].load(std::memory_order_relaxed)->blocks[i % kChunkBlocks];
    for (std::size_t w = 0; w < b.free.words.size(); ++w) b.free.words[w] &= ~b.hit.words[w];
  }
  for (auto& [key, counts] : overflow_)
    if (counts.second != 0) counts.first = 0;
}

void ScanEvidence::allocateLane(int lane, std::unique_ptr<BitPlane[]>& planes) {
  planes = std::make_unique<BitPlane[]>(kChunkBlocks);  // zeroed
  int used = lanes_used_.load(std::memory_order_relaxed);
  while (used < lane + 1 && !lanes_used_.compare_exchange_weak(used, lane + 1, std::memory_order_relaxed)) {
  }
}

void ScanEvidence::mergeFreeLanes() {
  const auto lanes = static_cast<std::size_t>(lanes_used_.load(std::memory_order_relaxed));
  if (lanes == 0) return;
  const std::size_t n = blockCount();
#pragma omp parallel for schedule(static)
  for (std::size_t i = 0; i < n; ++i) {
    Chunk* c = chunk_ptrs_[i / kChunkBlocks].load(std::memory_order_relaxed);
    EvidenceBlock& b = c->blocks[i % kChunkBlocks];
    for (std::size_t t = 0; t < lanes; ++t) {
      auto& planes = c->lanes[t];
      if (!planes) continue;
      BitPlane& lane = planes[i % kChunkBlocks];
      for (std::size_t w = 0; w < lane.words.size(); ++w) {
        b.free.words[w] |= lane.words[w];
        lane.words[w] = 0;
      }
    }
  }
}

std::uint64_t ScanEvidence::overflowHitCells() const {
  std::uint64_t cells = 0;
  for (const auto& [key, counts] : overflow_) cells += counts.second != 0 ? 1 : 0;
  return cells;
}

std::size_t ScanEvidence::blockCount() const { return std::min(used_.load(), capacity()); }

const EvidenceBlock& ScanEvidence::blockAt(std::size_t i) const {
  return chunk_ptrs_[i / kChunkBlocks].load(std::memory_order_acquire)->blocks[i % kChunkBlocks];
}

EvidenceBlock& ScanEvidence::blockAt(std::size_t i) {
  return chunk_ptrs_[i / kChunkBlocks].load(std::memory_order_acquire)->blocks[i % kChunkBlocks];
}

}  // namespace densemap::map
