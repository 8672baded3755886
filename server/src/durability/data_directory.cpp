#include "densemap/server/durability/data_directory.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <fstream>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "densemap/util/byte_codec.h"

namespace densemap::server::durability {

namespace fs = std::filesystem;

std::string mapFingerprint(const map::MapOptions& m, const update::UpdateOptions& u,
                           const dense::DenseLayerOptions& d) {
  const auto& p = m.params;
  std::string s = fmt::format(
      "backend={} resolution={} hit={} miss={} clamp={},{} occupied={} semantics={} "
      "max_range={}",
      m.backend, m.resolution, p.prob_hit, p.prob_miss, p.clamp_min, p.clamp_max, p.occupied_threshold,
      map::toString(u.semantics), u.max_range);
  if (m.decay.enabled())
    s += fmt::format(" decay={} decay_step={}", m.decay.seconds_to_unknown, m.decay.step_s);
  if (d.method != "none") {
    s += fmt::format(
        " dense={} dense_resolution={} free_sample={} free_voxel={} dense_max_range={} seed={} "
        "min_search={} isotropic_free={} min_occupied_search={}",
        d.method, d.resolution, d.free_sample_distance, d.free_voxel_size, d.max_range, d.seed,
        d.min_search_radius, d.isotropic_free_kernels, d.min_occupied_search_radius);
  }
  return s;
}

namespace {

std::string readWhole(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw RecoveryError(fmt::format("cannot read {}: {}", path.string(), std::strerror(errno)));
  in.seekg(0, std::ios::end);
  std::string bytes(static_cast<std::size_t>(in.tellg()), '\0');
  in.seekg(0);
  in.read(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  if (!in) throw RecoveryError(fmt::format("cannot read {}: {}", path.string(), std::strerror(errno)));
  return bytes;
}

template <class F>
std::vector<std::pair<std::uint64_t, fs::path>> listed(const fs::path& dir, F&& number) {
  std::vector<std::pair<std::uint64_t, fs::path>> out;
  for (const auto& e : fs::directory_iterator(dir)) {
    if (auto n = number(e.path().filename().string())) out.emplace_back(*n, e.path());
  }
  std::sort(out.begin(), out.end());
  return out;
}

void makeDir(const fs::path& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir))
    throw RecoveryError(
        fmt::format("cannot create the data directory {}: {}; give the server a directory it can "
                    "write (--data-dir)",
                    dir.string(), ec ? ec.message() : "not a directory"));
}

}  // namespace

DataDirectory::DataDirectory(fs::path dir, std::string fingerprint, DurabilityOptions options,
                             std::uint64_t max_record_bytes)
    : dir_(std::move(dir)),
      journal_dir_(dir_ / "journal"),
      snapshot_dir_(dir_ / "snapshots"),
      fingerprint_(std::move(fingerprint)),
      options_(std::move(options)),
      max_record_bytes_(max_record_bytes) {
  makeDir(dir_);
  makeDir(journal_dir_);
  makeDir(snapshot_dir_);
  const fs::path lock = dir_ / "LOCK";
  lock_fd_ = ::open(lock.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (lock_fd_ < 0)
    throw RecoveryError(
        fmt::format("cannot write in the data directory {} ({}: {}); give the server a directory "
                    "it can write (--data-dir) or run with --journal false",
                    dir_.string(), lock.string(), std::strerror(errno)));
  if (::flock(lock_fd_, LOCK_EX | LOCK_NB) != 0) {
    std::string holder(64, '\0');
    const ssize_t n = ::pread(lock_fd_, holder.data(), holder.size(), 0);
    holder.resize(n > 0 ? static_cast<std::size_t>(n) : 0);
    ::close(lock_fd_);
    lock_fd_ = -1;
    throw RecoveryError(
        fmt::format("the data directory {} is in use by another densemap-server (pid {}); stop it "
                    "or give this one another --data-dir",
                    dir_.string(), holder.empty() ? "unknown" : holder));
  }
  const std::string pid = std::to_string(::getpid());
  // A write test: a read-only directory fails here, before any scan is accepted.
  if (::ftruncate(lock_fd_, 0) != 0 || ::pwrite(lock_fd_, pid.data(), pid.size(), 0) < 0 ||
      ::fsync(lock_fd_) != 0)
    throw RecoveryError(
        fmt::format("cannot write in the data directory {}: {}; give the server a directory it "
                    "can write (--data-dir) or run with --journal false",
                    dir_.string(), std::strerror(errno)));
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(snapshot_dir_, ec)) {
    if (e.path().extension() == ".tmp") fs::remove(e.path(), ec);  // a snapshot a crash interrupted
  }
}

DataDirectory::~DataDirectory() {
  if (lock_fd_ >= 0) ::close(lock_fd_);  // releases the lock
}

RecoveryReport DataDirectory::recover(const SnapshotLoader& load, const RecordSink& replay) {
  const auto t0 = std::chrono::steady_clock::now();
  RecoveryReport report;
  const std::string what_to_do_snapshot =
      "The journal before it was removed when it was written, so the map cannot be rebuilt without it: "
      "restore "
      "the file from a backup, or move {} aside to start with an empty map";
  // 1. The newest snapshot. A damaged one is never skipped silently.
  const auto snapshots = listed(snapshot_dir_, snapshotLsn);
  std::uint64_t after = 0;
  if (!snapshots.empty()) {
    const fs::path& file = snapshots.back().second;
    SnapshotContents s;
    try {
      s = decodeSnapshot(readWhole(file));
    } catch (const util::FormatError& e) {
      throw RecoveryError(fmt::format("snapshot {} is damaged: {}. {}", file.string(), e.what(),
                                      fmt::format(fmt::runtime(what_to_do_snapshot), dir_.string())));
    }
    if (s.lsn != snapshots.back().first)
      throw RecoveryError(fmt::format("snapshot {} holds LSN {}, not the one its name says. {}",
                                      file.string(), s.lsn,
                                      fmt::format(fmt::runtime(what_to_do_snapshot), dir_.string())));
    if (s.fingerprint != fingerprint_)
      throw RecoveryError(
          fmt::format("the data directory {} was made with other map settings ({}) than this server's "
                      "({}); start with the same settings or another --data-dir",
                      dir_.string(), s.fingerprint, fingerprint_));
    try {
      load(s);
    } catch (const std::exception& e) {
      throw RecoveryError(fmt::format("snapshot {} does not load: {}. {}", file.string(), e.what(),
                                      fmt::format(fmt::runtime(what_to_do_snapshot), dir_.string())));
    }
    after = s.lsn;
    report.snapshot_lsn = s.lsn;
    report.snapshot_file = file.string();
  }
  // 2. The journal after it, segment by segment, without gaps.
  const auto segments = listed(journal_dir_, segmentFirstLsn);
  std::uint64_t expect = after + 1;  // the next LSN the map needs
  std::uint64_t last = after;
  bool cut = false;
  for (std::size_t i = 0; i < segments.size(); ++i) {
    const fs::path& file = segments[i].second;
    if (cut) {  // after damage that journal_recover=cut cut off
      fs::rename(file, file.string() + ".damaged");
      continue;
    }
    const bool newest = i + 1 == segments.size();
    // A segment entirely before the snapshot is left from a removal a crash interrupted.
    if (!newest && segments[i + 1].first <= expect) continue;
    const std::string bytes = readWhole(file);
    const SegmentScan scan = scanSegment(bytes, file.string(), max_record_bytes_);
    if (scan.damage || scan.header.fingerprint != fingerprint_) {
      if (!scan.damage) {
        throw RecoveryError(
            fmt::format("journal {} was written with other map settings ({}) than this server's ({}); "
                        "start with the same settings or another --data-dir",
                        file.string(), scan.header.fingerprint, fingerprint_));
      }
    }
    if (!scan.damage && scan.header.first_lsn != segments[i].first)
      throw RecoveryError(
          fmt::format("journal {} starts at record {}, not the one its name says; move it aside "
                      "after checking where it came from",
                      file.string(), scan.header.first_lsn));
    if (scan.header.first_lsn > expect && !(scan.damage && scan.valid_bytes == 0))
      throw RecoveryError(
          fmt::format("the journal misses records {} to {} (before {}); restore them from a backup, "
                      "or move {} aside to start with an empty map",
                      expect, scan.header.first_lsn - 1, file.string(), dir_.string()));
    for (const RecordView& r : scan.records) {
      if (r.lsn < expect) continue;
      try {
        replay(r, payloadOf(r, max_record_bytes_));
      } catch (const std::exception& e) {
        throw RecoveryError(
            fmt::format("journal {} record {} at offset {} does not replay: {}; it checks, so it was "
                        "written by another version: start that version, or move {} aside",
                        file.string(), r.lsn, r.offset, e.what(), dir_.string()));
      }
      ++report.records_replayed;
      last = r.lsn;
      expect = r.lsn + 1;
    }
    if (scan.damage) {
      const JournalDamage& d = *scan.damage;
      if (newest && d.torn_tail) {
        spdlog::warn("journal: {}; cut off there: the write that a crash cut short, never acknowledged",
                     d.describe());
      } else if (options_.journal_recover == "cut") {
        spdlog::error("journal: {}; cut there as --journal-recover cut asks: the records after it are lost",
                      d.describe());
        fs::copy_file(file, file.string() + ".damaged", fs::copy_options::overwrite_existing);
        cut = true;
      } else {
        throw RecoveryError(fmt::format(
            "journal {}. The records before it are intact and the ones after it cannot be trusted. To start "
            "from the intact part (losing what follows), run once with --journal-recover cut (the damaged "
            "rest "
            "is kept as *.damaged); or restore the file from a backup",
            d.describe()));
      }
      report.damage.push_back(d);
      if (scan.valid_bytes == 0) {  // not even a header: the segment was being created
        std::error_code ec;
        fs::remove(file, ec);
        continue;
      }
    }
    if (newest || cut) {
      tail_segment_ = file;
      tail_valid_bytes_ = scan.valid_bytes;
    }
  }
  report.last_lsn = last;
  next_lsn_ = last + 1;
  // A tail segment that starts after the records found (it only had a header) is continued only if it
  // starts exactly at the next LSN.
  if (tail_segment_ && segmentFirstLsn(tail_segment_->filename().string()).value_or(0) > next_lsn_) {
    tail_segment_.reset();
  }
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return report;
}

std::unique_ptr<JournalWriter> DataDirectory::openWriter() {
  try {
    return std::make_unique<JournalWriter>(journal_dir_, fingerprint_, next_lsn_, tail_segment_,
                                           tail_valid_bytes_, options_.journal_zstd_level,
                                           static_cast<std::uint64_t>(options_.journal_segment_mib) << 20);
  } catch (const StorageError& e) {
    throw RecoveryError(std::string(e.what()) + "; give the server a directory it can write (--data-dir)");
  }
}

std::uint64_t DataDirectory::writeSnapshot(const SnapshotContents& s) {
  const std::string bytes = encodeSnapshot(s);
  writeFileAtomically(snapshot_dir_ / snapshotFileName(s.lsn), bytes);
  std::error_code ec;
  bool removed = false;
  for (const auto& [lsn, path] : listed(snapshot_dir_, snapshotLsn)) {
    if (lsn < s.lsn) removed |= fs::remove(path, ec);
  }
  // Segments whose records all precede the snapshot (the open one, the newest, always stays).
  const auto segments = listed(journal_dir_, segmentFirstLsn);
  for (std::size_t i = 0; i + 1 < segments.size(); ++i) {
    if (segments[i + 1].first <= s.lsn + 1) removed |= fs::remove(segments[i].second, ec);
  }
  if (removed) {
    syncDirectory(snapshot_dir_);
    syncDirectory(journal_dir_);
  }
  return bytes.size();
}

}  // namespace densemap::server::durability
