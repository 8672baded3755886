// The journal's files: DATA_DIR/journal/<first LSN, 20 digits>.dmj, each a header and then records
//
//   record = magic u32 | kind u32 | lsn u64 | flags u32 | payload length u64 | payload CRC-32 u32 |
//            header CRC-32 u32 (of the 32 bytes before it) | payload
//
// LSNs (log sequence numbers) count every record from 1, without gaps, across segments. A reader keeps
// the valid prefix and says where and how the rest is damaged: a record that does not check with no
// valid record after it is a torn tail (the write a crash cut short; never acknowledged), anything else
// is damage in the middle.
#pragma once

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "densemap/server/durability/journal_record.h"

namespace densemap::server::durability {

/// A journal or snapshot file that cannot be written (full disk, read-only directory, I/O error).
class StorageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

inline constexpr std::uint32_t kRecordZstd = 1;  ///< flags: the payload is zstd-compressed
inline constexpr std::size_t kRecordHeaderBytes = 36;

struct SegmentHeader {
  std::uint64_t first_lsn = 1;
  std::int64_t created_ns = 0;
  std::string fingerprint;  ///< the map settings the records were made with (see mapFingerprint)
};

struct RecordView {
  RecordKind kind = RecordKind::kScan;
  std::uint64_t lsn = 0;
  std::uint32_t flags = 0;
  std::uint64_t offset = 0;  ///< of the record's header in its file
  std::string_view payload;  ///< as stored (compressed when flags say so)
};

struct JournalDamage {
  std::string file;
  std::uint64_t offset = 0;
  bool torn_tail = false;  ///< only a cut-short end; else damage with valid records after it
  std::string what;
  std::string describe() const;
};

struct SegmentScan {
  SegmentHeader header;
  std::vector<RecordView> records;
  std::uint64_t valid_bytes = 0;  ///< the header and every valid record
  std::optional<JournalDamage> damage;
};

/// Reads a segment's bytes (which must outlive the result). `max_payload` bounds a record's claimed size.
/// Never throws on damaged bytes: a header that does not check is damage at offset 0.
SegmentScan scanSegment(std::string_view bytes, const std::string& file, std::uint64_t max_payload);

/// A record's payload as encoded (decompressed when stored compressed). Throws util::FormatError.
std::string payloadOf(const RecordView& r, std::uint64_t max_payload);

std::string segmentFileName(std::uint64_t first_lsn);
/// The LSN a segment's file name starts at, or nullopt for names that are not segments.
std::optional<std::uint64_t> segmentFirstLsn(const std::string& file_name);
/// The LSN of a file named <20 digits><extension> (segments, snapshots), or nullopt.
std::optional<std::uint64_t> lsnOfFileName(const std::string& file_name, std::string_view extension);

/// fsync of a directory (after a file in it was created, renamed or removed). Throws StorageError.
void syncDirectory(const std::filesystem::path& dir);

/// Appends records to the newest segment; one writer thread.
class JournalWriter {
 public:
  /// Continues `segment` (cut back to `valid_bytes` when longer: a torn tail) or, when empty, starts one
  /// at `next_lsn`. Throws StorageError.
  JournalWriter(std::filesystem::path dir, std::string fingerprint, std::uint64_t next_lsn,
                std::optional<std::filesystem::path> segment = std::nullopt, std::uint64_t valid_bytes = 0,
                int zstd_level = 0, std::uint64_t segment_bytes = std::uint64_t{256} << 20);
  ~JournalWriter();
  JournalWriter(const JournalWriter&) = delete;
  JournalWriter& operator=(const JournalWriter&) = delete;

  /// Writes one record (not yet durable) and returns its LSN. On failure (e.g. ENOSPC) the file is cut
  /// back to where it was, the LSN is not used, and StorageError says what and where.
  std::uint64_t append(RecordKind kind, std::string_view payload);
  /// Makes every appended record durable (fdatasync). A failure poisons the writer (the kernel may have
  /// dropped the pages): later calls throw too, and the server must restart from what is on disk.
  void sync();
  /// Closes the segment (synced) and starts a new one at the next LSN; returns that LSN.
  std::uint64_t rotate();
  /// Removes whole segments whose records all have LSN <= `lsn` (the newest snapshot covers them).
  std::size_t dropThrough(std::uint64_t lsn);

  std::uint64_t lastLsn() const { return last_lsn_.load(); }
  std::uint64_t bytesAppended() const { return bytes_appended_; }
  std::uint64_t syncs() const { return syncs_; }
  std::uint64_t recordsAppended() const { return records_appended_; }
  const std::string& lastError() const { return poisoned_; }
  const std::filesystem::path& dir() const { return dir_; }
  bool poisoned() const { return poisoned_flag_.load(); }

 private:
  void openNew();
  void checkUsable() const;

  std::filesystem::path dir_;
  std::string fingerprint_;
  std::uint64_t next_lsn_;
  int zstd_level_;
  std::uint64_t segment_bytes_;
  int fd_ = -1;
  std::filesystem::path path_;
  std::uint64_t size_ = 0;
  std::uint64_t first_lsn_ = 0;
  std::atomic<std::uint64_t> bytes_appended_{0}, syncs_{0}, records_appended_{0}, last_lsn_{0};
  bool dirty_ = false;
  std::atomic<bool> poisoned_flag_{false};
  std::string poisoned_;  // written by the writer thread only; read after poisoned() by the same thread
};

}  // namespace densemap::server::durability
