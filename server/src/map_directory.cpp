#include "densemap/server/map_directory.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <stdexcept>

#include <fmt/format.h>

#include "densemap/server/file_descriptor_io.h"
#include "densemap/server/request_error.h"

namespace densemap::server {

namespace {

constexpr std::size_t kMaxNameLength = 128;

}  // namespace

int MapDirectory::descriptor(bool create) const {
  std::lock_guard lock(mutex_);
  if (fd_ >= 0) return fd_;
  std::error_code ec;
  if (create && std::filesystem::create_directories(dir_, ec)) {
    ::chmod(dir_.c_str(), 0750);  // maps hold a site's layout: not for other users
  }
  if (ec)
    throw RequestError(Status::kFailed,
                       "cannot create the map directory " + dir_.string() + ": " + ec.message());
  fd_ = ::open(dir_.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd_ < 0) {
    if (errno == ENOENT && !create)
      throw RequestError(Status::kNotFound, "no map directory " + dir_.string() + " yet (nothing was saved)");
    throw RequestError(Status::kFailed,
                       "cannot open the map directory " + dir_.string() + ": " + errnoText());
  }
  return fd_;
}

MapDirectory::~MapDirectory() {
  if (fd_ >= 0) ::close(fd_);
}

std::string MapDirectory::checkName(std::string_view name) {
  if (name.empty()) return "no map name given (NAME.bt or NAME.ot)";
  if (name.find('/') != std::string_view::npos)
    return fmt::format(
        "'{}' is a path; name a file in the server's map directory instead (NAME.bt or NAME.ot, no '/')",
        name.substr(0, kMaxNameLength));
  if (name.front() == '.') return "a map name may not start with '.'";
  if (name.size() > kMaxNameLength)
    return fmt::format("a map name has at most {} characters", kMaxNameLength);
  for (const char c : name) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' ||
                    c == '_' || c == '-';
    if (!ok) return "a map name may hold only letters, digits, '.', '_' and '-'";
  }
  if (!name.ends_with(".bt") && !name.ends_with(".ot")) return "a map name must end in .bt or .ot";
  if (name.size() == 3) return "a map name needs a stem before .bt or .ot";
  return {};
}

void MapDirectory::write(std::string_view name, std::string_view bytes) const {
  if (const std::string why = checkName(name); !why.empty())
    throw RequestError(Status::kInvalidArgument, why);
  const int dir = descriptor(true);
  static std::atomic<unsigned> counter{0};
  const std::string tmp = fmt::format(".{}.{}.{}.tmp", name, ::getpid(), counter++);
  const int fd = ::openat(dir, tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0640);
  if (fd < 0)
    throw RequestError(Status::kFailed,
                       fmt::format("cannot write in the map directory {}: {}", dir_.string(), errnoText()));
  const std::string write_error = writeAll(fd, bytes);
  const bool ok = write_error.empty() && ::fsync(fd) == 0;
  ::close(fd);
  // renameat replaces `name` itself, a symbolic link included, and never follows it.
  if (!ok || ::renameat(dir, tmp.c_str(), dir, std::string(name).c_str()) != 0) {
    const std::string why = write_error.empty() ? errnoText() : write_error;
    ::unlinkat(dir, tmp.c_str(), 0);
    throw RequestError(Status::kFailed, fmt::format("cannot save {} in {}: {}", name, dir_.string(), why));
  }
}

std::string MapDirectory::read(std::string_view name, std::size_t max_bytes) const {
  if (const std::string why = checkName(name); !why.empty())
    throw RequestError(Status::kInvalidArgument, why);
  const int dir = descriptor(false);
  const int fd = ::openat(dir, std::string(name).c_str(), O_RDONLY | O_NOFOLLOW | O_CLOEXEC | O_NONBLOCK);
  if (fd < 0) {
    if (errno == ENOENT)
      throw RequestError(Status::kNotFound, fmt::format("no map {} in {}", name, dir_.string()));
    if (errno == ELOOP)
      throw RequestError(
          Status::kInvalidArgument,
          fmt::format("{} is a symbolic link; maps are loaded only from files in {}", name, dir_.string()));
    throw RequestError(Status::kFailed, fmt::format("cannot open {}: {}", name, errnoText()));
  }
  RegularFileRead r = readRegularFile(fd, max_bytes);
  if (r.too_large) {
    ::close(fd);
    throw RequestError(Status::kInvalidArgument,
                       fmt::format("{} has {} bytes; the server loads at most {}", name, r.size, max_bytes));
  }
  const std::string error = r.error;
  std::string bytes = std::move(r.bytes);
  ::close(fd);
  if (!error.empty()) throw RequestError(Status::kFailed, fmt::format("cannot read {}: {}", name, error));
  return bytes;
}

}  // namespace densemap::server
