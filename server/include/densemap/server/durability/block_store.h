// Map blocks out of memory (the rolling window), one file each:
//
//   DATA_DIR/blocks/<block id, 16 hex digits>-<version, 20 digits>.dmb      (PaletteBlock::encode bytes)
//
// A file is written once and never changed: a block that leaves memory again gets a new version, so an
// index of (block, version) pairs kept in a snapshot stays valid until a newer snapshot replaces it, and
// collect() removes only what no index still names. Writes are not synced one by one; sync() makes every
// file written since the last call durable (before a snapshot names them).
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace densemap::server::durability {

std::string blockFileName(std::uint64_t id, std::uint64_t version);
/// The (block id, version) a file name stands for; nullopt for any other name (temporary files included).
std::optional<std::pair<std::uint64_t, std::uint64_t>> parseBlockFileName(std::string_view name);

class BlockStore {
 public:
  /// Creates the directory if needed. Throws StorageError when it cannot.
  explicit BlockStore(std::filesystem::path dir, std::size_t max_block_bytes = std::size_t{1} << 20);

  /// Writes a block's bytes under its version (a temporary file renamed into place). Throws StorageError.
  void put(std::uint64_t id, std::uint64_t version, std::string_view bytes);
  /// A block's bytes. Throws StorageError naming the file when it is missing, not a regular file (a
  /// symbolic link included), larger than the limit, or unreadable.
  std::string get(std::uint64_t id, std::uint64_t version) const;
  /// Removes one block file now (no snapshot can name it: the service runs without a journal).
  void remove(std::uint64_t id, std::uint64_t version);
  /// fsync of every file put since the last sync, then of the directory. Throws StorageError.
  void sync() { syncFiles(unsynced_); }
  /// The names of the files put since the last call (or sync), handed to syncFiles on another thread.
  std::vector<std::string> takeUnsynced();
  /// fsync of the named files (a file collected meanwhile is skipped), then of the directory. Safe beside
  /// put() and collect() on another thread: it reads only the directory's name. Synced names leave `names`
  /// as it goes, so after a StorageError it holds the ones still to sync.
  void syncFiles(std::vector<std::string>& names) const;
  /// Removes every block file whose (id, version) `keep` refuses, and leftover temporary files; returns
  /// how many files went. Names that are neither are left alone.
  std::size_t collect(const std::function<bool(std::uint64_t id, std::uint64_t version)>& keep);

  const std::filesystem::path& dir() const { return dir_; }
  /// Bytes put minus bytes collected since this store was opened, plus what collect() found on disk.
  std::uint64_t bytesOnDisk() const { return bytes_on_disk_; }

 private:
  std::filesystem::path dir_;
  std::size_t max_block_bytes_;
  std::vector<std::string> unsynced_;
  std::uint64_t bytes_on_disk_ = 0;
};

}  // namespace densemap::server::durability
