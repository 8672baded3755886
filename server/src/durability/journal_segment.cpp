#include "densemap/server/durability/journal_segment.h"

#include <fcntl.h>
#include <unistd.h>
#include <zlib.h>
#include <zstd.h>

#include <cerrno>
#include <cstring>

#include <fmt/format.h>

#include "densemap/server/durability/checksum.h"
#include "densemap/server/file_descriptor_io.h"
#include "densemap/util/byte_codec.h"
#include "densemap/util/wall_clock.h"

namespace densemap::server::durability {

namespace {

constexpr std::uint64_t kSegmentMagic = 0x31304C4E524A4D44ull;  // "DMJRNL01"
constexpr std::uint32_t kSegmentVersion = 1;
constexpr std::uint32_t kRecordMagic = 0x524A4D44;  // "DMJR"

struct ParsedHeader {
  RecordView view;
  std::uint32_t payload_crc = 0;
  std::uint64_t length = 0;
};

/// The record header at `pos` when it checks (magic and its own CRC).
std::optional<ParsedHeader> headerAt(std::string_view bytes, std::size_t pos) {
  if (bytes.size() - pos < kRecordHeaderBytes) return std::nullopt;
  util::ByteReader r(bytes.substr(pos, kRecordHeaderBytes));
  if (r.get<std::uint32_t>("magic") != kRecordMagic) return std::nullopt;
  ParsedHeader h;
  h.view.kind = static_cast<RecordKind>(r.get<std::uint32_t>("kind"));
  h.view.lsn = r.get<std::uint64_t>("lsn");
  h.view.flags = r.get<std::uint32_t>("flags");
  h.length = r.get<std::uint64_t>("length");
  h.payload_crc = r.get<std::uint32_t>("payload crc");
  const auto header_crc = r.get<std::uint32_t>("header crc");
  if (header_crc != crc32Of(bytes.substr(pos, kRecordHeaderBytes - 4))) return std::nullopt;
  h.view.offset = pos;
  return h;
}

/// Is there any whole, checking record somewhere after `from`? (Tells damage in the middle from a torn tail.)
bool validRecordAfter(std::string_view bytes, std::size_t from, std::uint64_t max_payload) {
  const char magic[4] = {'D', 'M', 'J', 'R'};
  for (std::size_t pos = from; pos + kRecordHeaderBytes <= bytes.size(); ++pos) {
    const void* hit = std::memchr(bytes.data() + pos, magic[0], bytes.size() - pos);
    if (hit == nullptr) return false;
    pos = static_cast<std::size_t>(static_cast<const char*>(hit) - bytes.data());
    if (pos + kRecordHeaderBytes > bytes.size()) return false;
    if (std::memcmp(bytes.data() + pos, magic, 4) != 0) continue;
    auto h = headerAt(bytes, pos);
    if (!h || h->length > max_payload || h->length > bytes.size() - pos - kRecordHeaderBytes) continue;
    if (crc32Of(bytes.substr(pos + kRecordHeaderBytes, h->length)) == h->payload_crc) return true;
  }
  return false;
}

}  // namespace

std::string JournalDamage::describe() const {
  return fmt::format("{} at offset {}: {}{}", file, offset, what,
                     torn_tail ? " (a torn tail: the last write, cut short)" : "");
}

SegmentScan scanSegment(std::string_view bytes, const std::string& file, std::uint64_t max_payload) {
  SegmentScan s;
  auto damage = [&](std::uint64_t offset, bool torn, std::string what) {
    s.damage = JournalDamage{file, offset, torn, std::move(what)};
    return s;
  };
  std::size_t pos = 0;
  try {
    util::ByteReader r(bytes);
    if (r.get<std::uint64_t>("segment magic") != kSegmentMagic)
      return damage(0, false, "not a journal segment");
    if (const auto v = r.get<std::uint32_t>("segment version"); v != kSegmentVersion)
      return damage(8, false, fmt::format("journal version {} (this server reads {})", v, kSegmentVersion));
    s.header.first_lsn = r.get<std::uint64_t>("first lsn");
    s.header.created_ns = r.get<std::int64_t>("created");
    s.header.fingerprint = r.string("fingerprint", 1 << 16);
    const std::size_t end = r.offset();
    if (r.get<std::uint32_t>("segment header crc") != crc32Of(bytes.substr(0, end)))
      return damage(end, false, "the segment header fails its checksum");
    pos = r.offset();
  } catch (const util::FormatError& e) {
    // A header cut short: the segment was being created when the process stopped.
    return damage(e.offset(), true, std::string("segment header cut short: ") + e.what());
  }
  s.valid_bytes = pos;
  std::uint64_t expect = s.header.first_lsn;
  while (pos < bytes.size()) {
    std::string why;
    auto h = headerAt(bytes, pos);
    if (!h) {
      why = bytes.size() - pos < kRecordHeaderBytes ? "a record header cut short"
                                                    : "a record header that fails its checksum";
    } else if (h->length > max_payload) {
      why = fmt::format("a record claiming {} bytes (at most {})", h->length, max_payload);
    } else if (h->length > bytes.size() - pos - kRecordHeaderBytes) {
      why = fmt::format("a record of {} bytes cut short at {}", h->length,
                        bytes.size() - pos - kRecordHeaderBytes);
    } else if (crc32Of(bytes.substr(pos + kRecordHeaderBytes, h->length)) != h->payload_crc) {
      why = fmt::format("record {} fails its checksum", h->view.lsn);
    } else if (h->view.lsn != expect) {
      why = fmt::format("record {} where record {} was due", h->view.lsn, expect);
    } else if (h->view.kind < RecordKind::kScan || h->view.kind > RecordKind::kLoad ||
               (h->view.flags & ~kRecordZstd) != 0) {
      why = fmt::format("record {} of unknown kind {} or flags {}", h->view.lsn,
                        static_cast<std::uint32_t>(h->view.kind), h->view.flags);
    }
    if (!why.empty()) {
      const bool torn = !validRecordAfter(bytes, pos + 1, max_payload);
      return damage(pos, torn, why);
    }
    h->view.payload = bytes.substr(pos + kRecordHeaderBytes, h->length);
    s.records.push_back(h->view);
    pos += kRecordHeaderBytes + h->length;
    s.valid_bytes = pos;
    ++expect;
  }
  return s;
}

std::string payloadOf(const RecordView& r, std::uint64_t max_payload) {
  if ((r.flags & kRecordZstd) == 0) return std::string(r.payload);
  const unsigned long long n = ZSTD_getFrameContentSize(r.payload.data(), r.payload.size());
  if (n == ZSTD_CONTENTSIZE_ERROR || n == ZSTD_CONTENTSIZE_UNKNOWN || n > max_payload)
    throw util::FormatError(
        fmt::format("record {}: not a zstd frame of a known size up to {} bytes", r.lsn, max_payload),
        r.offset);
  std::string out(n, '\0');
  const std::size_t got = ZSTD_decompress(out.data(), out.size(), r.payload.data(), r.payload.size());
  if (ZSTD_isError(got) || got != n)
    throw util::FormatError(
        fmt::format("record {}: zstd: {}", r.lsn, ZSTD_isError(got) ? ZSTD_getErrorName(got) : "short frame"),
        r.offset);
  return out;
}

std::string segmentFileName(std::uint64_t first_lsn) { return fmt::format("{:020}.dmj", first_lsn); }

std::optional<std::uint64_t> segmentFirstLsn(const std::string& name) { return lsnOfFileName(name, ".dmj"); }

std::optional<std::uint64_t> lsnOfFileName(const std::string& name, std::string_view extension) {
  if (name.size() != 20 + extension.size() || !name.ends_with(extension)) return std::nullopt;
  std::uint64_t v = 0;
  for (std::size_t i = 0; i < 20; ++i) {
    if (name[i] < '0' || name[i] > '9') return std::nullopt;
    v = v * 10 + static_cast<std::uint64_t>(name[i] - '0');
  }
  return v;
}

void syncDirectory(const std::filesystem::path& dir) {
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) throw StorageError(fmt::format("cannot open {} to sync it: {}", dir.string(), errnoText()));
  const int rc = ::fsync(fd);
  const std::string err = rc != 0 ? errnoText() : "";
  ::close(fd);
  if (rc != 0) throw StorageError(fmt::format("cannot sync directory {}: {}", dir.string(), err));
}

namespace {

/// Writes all of `data` at `offset` (pwrite); false with errno set on failure.
bool pwriteAll(int fd, const char* data, std::size_t n, std::uint64_t offset) {
  while (n > 0) {
    const ssize_t w = ::pwrite(fd, data, n, static_cast<off_t>(offset));
    if (w < 0) {
      if (errno == EINTR) continue;
      return false;
    }
    if (w == 0) {
      errno = EIO;
      return false;
    }
    data += w;
    n -= static_cast<std::size_t>(w);
    offset += static_cast<std::uint64_t>(w);
  }
  return true;
}

}  // namespace

JournalWriter::JournalWriter(std::filesystem::path dir, std::string fingerprint, std::uint64_t next_lsn,
                             std::optional<std::filesystem::path> segment, std::uint64_t valid_bytes,
                             int zstd_level, std::uint64_t segment_bytes)
    : dir_(std::move(dir)),
      fingerprint_(std::move(fingerprint)),
      next_lsn_(next_lsn),
      zstd_level_(zstd_level),
      segment_bytes_(segment_bytes),
      last_lsn_(next_lsn - 1) {
  if (!segment) {
    openNew();
    return;
  }
  path_ = *segment;
  fd_ = ::open(path_.c_str(), O_WRONLY | O_CLOEXEC);
  if (fd_ < 0)
    throw StorageError(fmt::format("cannot open journal {} for writing: {}", path_.string(), errnoText()));
  // A torn tail is cut off, so new records follow the last valid one.
  if (::ftruncate(fd_, static_cast<off_t>(valid_bytes)) != 0 || ::fsync(fd_) != 0) {
    const std::string err = errnoText();
    ::close(fd_);
    throw StorageError(
        fmt::format("cannot cut journal {} back to {} bytes: {}", path_.string(), valid_bytes, err));
  }
  size_ = valid_bytes;
  first_lsn_ = segmentFirstLsn(path_.filename().string()).value_or(next_lsn);
}

JournalWriter::~JournalWriter() {
  if (fd_ >= 0) {
    if (dirty_ && !poisoned()) ::fdatasync(fd_);
    ::close(fd_);
  }
}

void JournalWriter::checkUsable() const {
  if (poisoned()) throw StorageError(poisoned_);
}

void JournalWriter::openNew() {
  std::error_code ec;
  std::filesystem::create_directories(dir_, ec);
  if (ec)
    throw StorageError(
        fmt::format("cannot create the journal directory {}: {}", dir_.string(), ec.message()));
  std::string header;
  util::ByteWriter w(header);
  w.put(kSegmentMagic);
  w.put(kSegmentVersion);
  w.put(next_lsn_);
  w.put(util::wallClockNs());
  w.string(fingerprint_);
  w.put(crc32Of(header));
  const std::filesystem::path path = dir_ / segmentFileName(next_lsn_);
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) throw StorageError(fmt::format("cannot create journal {}: {}", path.string(), errnoText()));
  if (!pwriteAll(fd, header.data(), header.size(), 0) || ::fsync(fd) != 0) {
    const std::string err = errnoText();
    ::close(fd);
    std::filesystem::remove(path, ec);
    throw StorageError(fmt::format("cannot write journal {}: {}", path.string(), err));
  }
  syncDirectory(dir_);
  if (fd_ >= 0) ::close(fd_);
  fd_ = fd;
  path_ = path;
  size_ = header.size();
  first_lsn_ = next_lsn_;
}

std::uint64_t JournalWriter::append(RecordKind kind, std::string_view payload) {
  checkUsable();
  if (size_ >= segment_bytes_ && next_lsn_ > first_lsn_) rotate();
  std::string compressed;
  std::uint32_t flags = 0;
  if (zstd_level_ > 0) {
    compressed.resize(ZSTD_compressBound(payload.size()));
    const std::size_t n =
        ZSTD_compress(compressed.data(), compressed.size(), payload.data(), payload.size(), zstd_level_);
    if (!ZSTD_isError(n) && n < payload.size()) {
      compressed.resize(n);
      payload = compressed;
      flags = kRecordZstd;
    }
  }
  std::string header;
  header.reserve(kRecordHeaderBytes);
  util::ByteWriter w(header);
  w.put(kRecordMagic);
  w.put(static_cast<std::uint32_t>(kind));
  w.put(next_lsn_);
  w.put(flags);
  w.put(static_cast<std::uint64_t>(payload.size()));
  w.put(crc32Of(payload));
  w.put(crc32Of(header));
  if (!pwriteAll(fd_, header.data(), header.size(), size_) ||
      !pwriteAll(fd_, payload.data(), payload.size(), size_ + header.size())) {
    const std::string err = errnoText();
    // Cut the partial record off, so the next record follows the last whole one.
    if (::ftruncate(fd_, static_cast<off_t>(size_)) != 0) {
      poisoned_ = fmt::format(
          "journal {}: a failed write could not be cut back at offset {} ({}); restart the "
          "server once the disk is fixed",
          path_.string(), size_, errnoText());
      poisoned_flag_ = true;
    }
    throw StorageError(
        fmt::format("cannot append to journal {} at offset {}: {}", path_.string(), size_, err));
  }
  size_ += header.size() + payload.size();
  bytes_appended_ += header.size() + payload.size();
  dirty_ = true;
  ++records_appended_;
  last_lsn_ = next_lsn_;
  return next_lsn_++;
}

void JournalWriter::sync() {
  checkUsable();
  if (!dirty_) return;
  if (::fdatasync(fd_) != 0) {
    // After a failed fsync the kernel may have dropped the dirty pages: nothing since the last good sync
    // can be trusted to be on disk, so this writer takes no more records (PostgreSQL's lesson).
    poisoned_ = fmt::format(
        "journal {}: fsync failed ({}); the records since the last sync may not be on disk. "
        "Fix the disk and restart the server: it rebuilds the map from what is on disk",
        path_.string(), errnoText());
    poisoned_flag_ = true;
    throw StorageError(poisoned_);
  }
  dirty_ = false;
  ++syncs_;
}

std::uint64_t JournalWriter::rotate() {
  sync();
  openNew();
  return next_lsn_;
}

std::size_t JournalWriter::dropThrough(std::uint64_t lsn) {
  std::vector<std::pair<std::uint64_t, std::filesystem::path>> segments;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(dir_, ec)) {
    if (auto first = segmentFirstLsn(e.path().filename().string())) segments.emplace_back(*first, e.path());
  }
  std::sort(segments.begin(), segments.end());
  std::size_t removed = 0;
  // A segment's records end where the next segment starts; the open segment is never removed.
  for (std::size_t i = 0; i + 1 < segments.size(); ++i) {
    if (segments[i + 1].first - 1 <= lsn && segments[i].second != path_) {
      if (std::filesystem::remove(segments[i].second, ec)) ++removed;
    }
  }
  if (removed > 0) syncDirectory(dir_);
  return removed;
}

}  // namespace densemap::server::durability
