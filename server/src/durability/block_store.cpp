#include "densemap/server/durability/block_store.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cstring>
#include <utility>

#include <fmt/format.h>

#include "densemap/server/durability/journal_segment.h"
#include "densemap/server/file_descriptor_io.h"

namespace densemap::server::durability {

namespace fs = std::filesystem;

namespace {
constexpr std::string_view kSuffix = ".dmb";
constexpr std::string_view kTmpSuffix = ".dmb.tmp";

/// Exactly `digits` characters of the given base.
std::optional<std::uint64_t> parseDigits(std::string_view s, std::size_t digits, int base) {
  if (s.size() != digits) return std::nullopt;
  for (char c : s) {
    const bool ok = base == 16 ? (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f') : (c >= '0' && c <= '9');
    if (!ok) return std::nullopt;
  }
  std::uint64_t v = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v, base);
  if (ec != std::errc() || end != s.data() + s.size()) return std::nullopt;  // e.g. too large for 64 bits
  return v;
}
}  // namespace

std::string blockFileName(std::uint64_t id, std::uint64_t version) {
  return fmt::format("{:016x}-{:020}{}", id, version, kSuffix);
}

std::optional<std::pair<std::uint64_t, std::uint64_t>> parseBlockFileName(std::string_view name) {
  if (!name.ends_with(kSuffix)) return std::nullopt;
  name.remove_suffix(kSuffix.size());
  if (name.size() != 16 + 1 + 20 || name[16] != '-') return std::nullopt;
  const auto id = parseDigits(name.substr(0, 16), 16, 16);
  const auto version = parseDigits(name.substr(17), 20, 10);
  if (!id || !version) return std::nullopt;
  return std::pair{*id, *version};
}

BlockStore::BlockStore(fs::path dir, std::size_t max_block_bytes)
    : dir_(std::move(dir)), max_block_bytes_(max_block_bytes) {
  std::error_code ec;
  fs::create_directories(dir_, ec);
  if (ec || !fs::is_directory(dir_))
    throw StorageError(fmt::format("cannot use {} for map blocks out of memory: {}", dir_.string(),
                                   ec ? ec.message() : "not a directory"));
}

void BlockStore::put(std::uint64_t id, std::uint64_t version, std::string_view bytes) {
  const std::string name = blockFileName(id, version);
  const fs::path tmp = dir_ / (name.substr(0, name.size() - kSuffix.size()) + std::string(kTmpSuffix));
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_NOFOLLOW | O_CLOEXEC, 0640);
  if (fd < 0) throw StorageError(fmt::format("cannot write {}: {}", tmp.string(), errnoText()));
  const std::string why = writeAll(fd, bytes);
  const bool ok = why.empty();
  ::close(fd);
  if (!ok || ::rename(tmp.c_str(), (dir_ / name).c_str()) != 0) {
    const std::string error = why.empty() ? errnoText() : why;
    ::unlink(tmp.c_str());
    throw StorageError(fmt::format("cannot write map block {} in {}: {}", name, dir_.string(), error));
  }
  unsynced_.push_back(name);
  bytes_on_disk_ += bytes.size();
}

std::string BlockStore::get(std::uint64_t id, std::uint64_t version) const {
  const fs::path path = dir_ / blockFileName(id, version);
  const int fd = ::open(path.c_str(), O_RDONLY | O_NOFOLLOW | O_CLOEXEC | O_NONBLOCK);
  if (fd < 0)
    throw StorageError(fmt::format("map block file {} cannot be opened: {}{}", path.string(), errnoText(),
                                   errno == ELOOP ? " (a symbolic link: refused)" : ""));
  RegularFileRead r = readRegularFile(fd, max_block_bytes_);
  const std::string error =
      r.too_large ? fmt::format("{} bytes, more than a block can have ({})", r.size, max_block_bytes_)
                  : r.error;
  std::string bytes = std::move(r.bytes);
  ::close(fd);
  if (!error.empty()) throw StorageError(fmt::format("map block file {}: {}", path.string(), error));
  return bytes;
}

void BlockStore::remove(std::uint64_t id, std::uint64_t version) {
  const fs::path path = dir_ / blockFileName(id, version);
  struct stat st {};
  if (::lstat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode) && ::unlink(path.c_str()) == 0) {
    const auto size = static_cast<std::uint64_t>(st.st_size);
    bytes_on_disk_ -= std::min(bytes_on_disk_, size);
  }
}

std::vector<std::string> BlockStore::takeUnsynced() { return std::exchange(unsynced_, {}); }

void BlockStore::syncFiles(std::vector<std::string>& names) const {
  for (std::size_t done = 0; done < names.size(); ++done) {
    const fs::path path = dir_ / names[done];
    const int fd = ::open(path.c_str(), O_RDONLY | O_NOFOLLOW | O_CLOEXEC);
    if (fd < 0 && errno == ENOENT) continue;  // collected meanwhile
    const bool ok = fd >= 0 && ::fsync(fd) == 0;
    const std::string why = ok ? "" : errnoText();
    if (fd >= 0) ::close(fd);
    if (!ok) {
      names.erase(names.begin(), names.begin() + static_cast<std::ptrdiff_t>(done));  // the rest stay
      throw StorageError(fmt::format("cannot sync {}: {}", path.string(), why));
    }
  }
  names.clear();
  const int dfd = ::open(dir_.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd < 0 || ::fsync(dfd) != 0) {
    const std::string why = errnoText();
    if (dfd >= 0) ::close(dfd);
    throw StorageError(fmt::format("cannot sync the directory {}: {}", dir_.string(), why));
  }
  ::close(dfd);
}

std::size_t BlockStore::collect(const std::function<bool(std::uint64_t, std::uint64_t)>& keep) {
  std::size_t removed = 0;
  std::uint64_t kept_bytes = 0;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir_, ec)) {
    const std::string name = entry.path().filename().string();
    const auto parsed = parseBlockFileName(name);
    const bool tmp = name.ends_with(kTmpSuffix);
    if (!parsed && !tmp) continue;  // not ours
    std::error_code size_ec;
    const auto size = entry.is_regular_file(size_ec) ? entry.file_size(size_ec) : 0;
    if (parsed && keep(parsed->first, parsed->second)) {
      kept_bytes += size_ec ? 0 : size;
      continue;
    }
    if (::unlink(entry.path().c_str()) == 0) ++removed;
  }
  if (ec) throw StorageError(fmt::format("cannot list {}: {}", dir_.string(), ec.message()));
  bytes_on_disk_ = kept_bytes;
  return removed;
}

}  // namespace densemap::server::durability
