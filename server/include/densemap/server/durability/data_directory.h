// The service's data directory: DATA_DIR/LOCK (one server at a time), DATA_DIR/journal/ and
// DATA_DIR/snapshots/. Recovery loads the newest snapshot and hands every later journal record to the
// caller, in order; it reports damage with the file and offset, keeps the valid prefix, and either goes on
// (a torn tail) or refuses with a RecoveryError that says what to do.
#pragma once

#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "densemap/server/durability/durability_options.h"
#include "densemap/server/durability/journal_segment.h"
#include "densemap/server/durability/snapshot_file.h"

namespace densemap::server::durability {

/// The data directory cannot be used as it is; the message says why and what to do.
class RecoveryError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct RecoveryReport {
  std::optional<std::uint64_t> snapshot_lsn;
  std::string snapshot_file;
  std::uint64_t records_replayed = 0;
  std::uint64_t last_lsn = 0;
  std::vector<JournalDamage> damage;  ///< torn tails cut off (or, with journal_recover cut, damage cut)
  double seconds = 0.0;
};

class DataDirectory {
 public:
  /// Creates the directories and takes the lock. Throws RecoveryError (not writable, or in use).
  DataDirectory(std::filesystem::path dir, std::string fingerprint, DurabilityOptions options,
                std::uint64_t max_record_bytes);
  ~DataDirectory();
  DataDirectory(const DataDirectory&) = delete;
  DataDirectory& operator=(const DataDirectory&) = delete;

  using SnapshotLoader = std::function<void(const SnapshotContents&)>;
  using RecordSink = std::function<void(const RecordView& record, std::string payload)>;
  /// Loads the newest snapshot (through `load`) and replays the journal after it (through `replay`).
  /// Throws RecoveryError; exceptions of the callbacks become one naming the file and offset.
  RecoveryReport recover(const SnapshotLoader& load, const RecordSink& replay);
  /// The writer that continues after recover().
  std::unique_ptr<JournalWriter> openWriter();

  /// Writes a snapshot atomically, then removes older snapshots and the journal segments it covers.
  /// Returns the file's size. Throws StorageError.
  std::uint64_t writeSnapshot(const SnapshotContents& s);

  const std::filesystem::path& path() const { return dir_; }
  const std::filesystem::path& journalDir() const { return journal_dir_; }
  const std::filesystem::path& snapshotDir() const { return snapshot_dir_; }

 private:
  std::filesystem::path dir_, journal_dir_, snapshot_dir_;
  std::string fingerprint_;
  DurabilityOptions options_;
  std::uint64_t max_record_bytes_;
  int lock_fd_ = -1;
  std::uint64_t next_lsn_ = 1;
  std::optional<std::filesystem::path> tail_segment_;
  std::uint64_t tail_valid_bytes_ = 0;
};

}  // namespace densemap::server::durability
