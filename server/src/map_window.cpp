#include "densemap/server/map_window.h"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <unordered_set>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "densemap/server/durability/journal_segment.h"
#include "densemap/util/byte_codec.h"

namespace densemap::server {

namespace {
constexpr std::uint32_t kStateMagic = 0x31574D44;  // "DMW1"
}  // namespace

MapWindow::MapWindow(MapWindowOptions options, std::unique_ptr<durability::BlockStore> store)
    : options_(options), store_(std::move(store)) {
  if (options_.store && !store_) throw std::invalid_argument("the map window needs a block store");
  // Without a journal no snapshot names a file: what an earlier run left is of no use.
  if (store_ && !options_.snapshots) store_->collect([](std::uint64_t, std::uint64_t) { return false; });
}

std::size_t MapWindow::bringBack(map::GridMap& m, const geometry::VoxelKey& lo, const geometry::VoxelKey& hi,
                                 float reach_m, const Publisher& publish) {
  if (m.outOfMemoryCount() == 0) return 0;
  const std::size_t n = bringBackIds(m, m.outOfMemoryIn(lo, hi), publish);
  if (n == 0) return 0;
  came_back_ += n;
  // A radius below the sensor's range sends the far part of every scan out of memory and back with the
  // next one: correct, but every scan then pays a store and a load.
  if (options_.radius_m > 0.0 && reach_m > options_.radius_m && thrash_throttle_.due())
    spdlog::warn(
        "map window: a scan reaches {:.0f} m but --window-radius is {:.0f} m, so its far blocks leave memory "
        "after each scan and come back with the next ({} came back so far); make the radius at least the "
        "sensor's range",
        reach_m, options_.radius_m, came_back_.load());
  return n;
}

std::size_t MapWindow::bringBackForQuery(
    map::GridMap& m, const std::vector<std::pair<geometry::VoxelKey, geometry::VoxelKey>>& boxes,
    const Publisher& publish) {
  if (m.outOfMemoryCount() == 0) return 0;
  map::BlockIdSet wanted;
  for (const auto& [lo, hi] : boxes)
    for (std::uint64_t id : m.outOfMemoryIn(lo, hi)) wanted.insert(id);
  std::vector<std::uint64_t> ids;
  ids.reserve(wanted.size());
  wanted.forEach([&](std::uint64_t id) { ids.push_back(id); });
  const std::size_t n = bringBackIds(m, ids, publish);
  // Kept a while: the next scan would otherwise send them out again (they are far from every robot) before
  // the query is answered, or before the client's next query of the same place.
  for (std::uint64_t id : ids) pinned_[id] = last_scan_s_ + options_.query_load_s;
  loaded_for_queries_ += n;
  return n;
}

std::size_t MapWindow::bringBackIds(map::GridMap& m, const std::vector<std::uint64_t>& ids,
                                    const Publisher& publish) {
  if (ids.empty()) return 0;
  // Read and decode before taking the lock: readers wait only for the pointers to move.
  std::vector<std::pair<std::uint64_t, std::unique_ptr<map::PaletteBlock>>> back;
  for (std::uint64_t id : ids) {
    const std::uint64_t* version = index_.find(id);
    if (version == nullptr) {  // dropped (never stored): it comes back empty
      back.emplace_back(id, nullptr);
      continue;
    }
    try {
      back.emplace_back(
          id, std::make_unique<map::PaletteBlock>(map::PaletteBlock::decode(store_->get(id, *version))));
    } catch (const util::FormatError& e) {
      throw durability::StorageError(
          fmt::format("map block file {}: {}",
                      (store_->dir() / durability::blockFileName(id, *version)).string(), e.what()));
    }
  }
  publish([&] {
    for (auto& [id, block] : back) m.putBlock(id, std::move(block));
  });
  for (const auto& [id, block] : back) {
    const std::uint64_t* version = index_.find(id);
    if (version == nullptr) continue;
    if (!options_.snapshots) store_->remove(id, *version);
    index_.erase(id);
  }
  blocks_out_ = m.outOfMemoryCount();
  return back.size();
}

void MapWindow::afterScan(map::GridMap& m, const std::string& robot, const geometry::Vec3f& origin,
                          double now_s, const Publisher& publish) {
  collectPending();
  last_scan_s_ = now_s;
  for (const auto& [id, silent_s] : robots_.update(robot, origin, now_s)) {
    spdlog::info(
        "map window: robot '{}' sent nothing for {:.0f} s (--window-robot-timeout-s); its blocks may leave "
        "memory",
        id, silent_s);
    ++robots_forgotten_;
  }
  std::vector<std::uint64_t> ids;
  if (options_.radius_m > 0.0) ids = m.blocksFartherThan(robots_.positions(), options_.radius_m);
  unpin(now_s, ids);
  if (!ids.empty()) evict(m, ids, publish);
  if (options_.max_map_mb > 0.0) {
    const auto cap = static_cast<std::size_t>(options_.max_map_mb * 1e6);
    const std::size_t bytes = m.memoryBytes();
    // Past the cap, down to 90% of it, so the next scans do not each evict a little. Blocks a query holds
    // stay: the cap is then reached once their time is over.
    if (bytes > cap) {
      std::vector<std::uint64_t> lru = m.leastRecentlyUpdated(bytes - cap * 9 / 10);
      unpin(now_s, lru);
      evict(m, lru, publish);
    }
  }
}

void MapWindow::unpin(double now_s, std::vector<std::uint64_t>& ids) {
  if (pinned_.empty()) return;
  for (auto it = pinned_.begin(); it != pinned_.end();) {
    if (std::isnan(it->second)) it->second = now_s + options_.query_load_s;  // loaded before any scan
    it = now_s >= it->second ? pinned_.erase(it) : std::next(it);
  }
  std::erase_if(ids, [this](std::uint64_t id) { return pinned_.count(id) != 0; });
}

void MapWindow::evict(map::GridMap& m, const std::vector<std::uint64_t>& ids, const Publisher& publish) {
  // Written first, taken out after: a block leaves memory only once its file is there, so a full disk
  // costs memory, never cells.
  std::vector<std::uint64_t> leaving;
  leaving.reserve(ids.size());
  if (options_.store) {
    for (std::uint64_t id : ids) {
      const map::PaletteBlock* b = m.blockById(id);
      if (b == nullptr) continue;
      const std::string bytes = b->encode();
      const std::uint64_t version = ++version_;
      try {
        store_->put(id, version, bytes);
      } catch (const durability::StorageError& e) {
        ++store_failures_;
        if (throttle_.due())
          spdlog::warn("map window: {}; the map keeps its blocks in memory until the store can take them",
                       e.what());
        break;
      }
      index_.insert(id, version);
      bytes_stored_ += bytes.size();
      leaving.push_back(id);
    }
  } else {
    leaving = ids;
  }
  publish([&] {
    for (std::uint64_t id : leaving) {
      m.takeBlock(id);
      if (!options_.store) m.putBlock(id, nullptr);  // forgotten: not out of memory, just gone
    }
  });
  (options_.store ? left_ : dropped_) += leaving.size();
  blocks_out_ = m.outOfMemoryCount();
}

void MapWindow::forgetAll() {
  if (store_ && !options_.snapshots) store_->collect([](std::uint64_t, std::uint64_t) { return false; });
  index_.clear();
  pinned_.clear();
  blocks_out_ = 0;
}

MapWindow::SnapshotPart MapWindow::snapshotPart() {
  // The previous snapshot's collect first: it keeps only what that snapshot or the live index names, so
  // done after this state is taken it could remove a file this state names (a block back since).
  collectPending();
  SnapshotPart part;
  if (store_) {
    part.files_to_sync = store_->takeUnsynced();
    std::lock_guard lock(pending_mutex_);
    part.files_to_sync.insert(part.files_to_sync.end(), resync_.begin(), resync_.end());
    resync_.clear();
  }
  util::ByteWriter w(part.state);
  w.put(kStateMagic);
  w.put(version_);
  w.put(static_cast<std::uint64_t>(robots_.byRobot().size()));
  for (const auto& [id, p] : robots_.byRobot()) {
    w.string(id);
    w.put(p.x());
    w.put(p.y());
    w.put(p.z());
  }
  w.put(static_cast<std::uint64_t>(index_.size()));
  index_.forEach([&](std::uint64_t id, std::uint64_t version) {
    w.put(id);
    w.put(version);
  });
  return part;
}

void MapWindow::syncStored(std::vector<std::string> files) {
  if (!store_) return;
  try {
    store_->syncFiles(files);
  } catch (const durability::StorageError&) {
    std::lock_guard lock(pending_mutex_);
    resync_.insert(resync_.end(), files.begin(), files.end());
    throw;
  }
}

std::string MapWindow::snapshotState() {
  SnapshotPart part = snapshotPart();
  syncStored(std::move(part.files_to_sync));
  return std::move(part.state);
}

namespace {
struct DecodedState {
  std::uint64_t version = 0;
  std::map<std::string, geometry::Vec3f> robots;
  map::BlockIdMap<std::uint64_t> index;
};

DecodedState decodeState(std::string_view bytes) {
  util::ByteReader r(bytes);
  if (r.get<std::uint32_t>("window magic") != kStateMagic) r.fail("not a map window state");
  DecodedState s;
  s.version = r.get<std::uint64_t>("window version");
  const std::uint64_t robots = r.count("robots", 4 + 12);
  for (std::uint64_t i = 0; i < robots; ++i) {
    std::string id = r.string("robot id", 256);
    const float x = r.get<float>("x"), y = r.get<float>("y"), z = r.get<float>("z");
    if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z)) r.fail("a robot position is not finite");
    s.robots[std::move(id)] = geometry::Vec3f(x, y, z);
  }
  const std::uint64_t blocks = r.count("stored blocks", 16);
  for (std::uint64_t i = 0; i < blocks; ++i) {
    const auto id = r.get<std::uint64_t>("block id");
    const auto version = r.get<std::uint64_t>("block version");
    if (!map::GridMap::isBlockId(id)) r.fail("a stored block's id is not a map block's");
    if (version == 0 || version > s.version) r.fail("a stored block's version is past the window's counter");
    if (!s.index.insert(id, version)) r.fail("a block stored twice");
  }
  if (!r.done()) r.fail("bytes after the window state");
  return s;
}
}  // namespace

void MapWindow::restoreState(std::string_view state, map::GridMap& m) {
  DecodedState s = decodeState(state);
  version_ = s.version;
  robots_.clear();
  for (auto& [id, p] : s.robots) robots_.restore(id, p);
  index_ = std::move(s.index);
  if (!options_.store && !index_.empty())
    throw std::runtime_error(
        "the snapshot has stored map blocks but the server drops them (--evicted-blocks)");
  index_.forEach([&](std::uint64_t id, std::uint64_t) { m.markOutOfMemory(id); });
  blocks_out_ = m.outOfMemoryCount();
}

void MapWindow::snapshotWritten(std::string state) {
  std::lock_guard lock(pending_mutex_);
  pending_collect_ = std::move(state);
}

void MapWindow::collectPending() {
  std::optional<std::string> state;
  {
    std::lock_guard lock(pending_mutex_);
    state.swap(pending_collect_);
  }
  if (!state || !store_) return;
  const DecodedState snap = decodeState(*state);
  const std::size_t removed = store_->collect([&](std::uint64_t id, std::uint64_t version) {
    const std::uint64_t* a = snap.index.find(id);
    const std::uint64_t* b = index_.find(id);
    return (a != nullptr && *a == version) || (b != nullptr && *b == version);
  });
  if (removed > 0) spdlog::debug("map window: removed {} block files no index names", removed);
}

MapWindow::Stats MapWindow::stats() const {
  return {blocks_out_.load(),   left_.load(),           came_back_.load(),        dropped_.load(),
          bytes_stored_.load(), store_failures_.load(), robots_forgotten_.load(), loaded_for_queries_.load()};
}

}  // namespace densemap::server
