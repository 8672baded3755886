#include "densemap/server/file_descriptor_io.h"

#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace densemap::server {

std::string errnoText() { return std::strerror(errno); }

std::string writeAll(int fd, std::string_view bytes) {
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return n == 0 ? std::string(std::strerror(EIO)) : std::string(std::strerror(errno));
    done += static_cast<std::size_t>(n);
  }
  return {};
}

RegularFileRead readRegularFile(int fd, std::uint64_t max_bytes) {
  RegularFileRead r;
  struct stat st {};
  if (::fstat(fd, &st) != 0) {
    r.error = std::strerror(errno);
    return r;
  }
  if (!S_ISREG(st.st_mode)) {
    r.error = "not a regular file";
    return r;
  }
  r.size = static_cast<std::uint64_t>(st.st_size);
  if (r.size > max_bytes) {
    r.too_large = true;
    r.error = "larger than the limit";
    return r;
  }
  r.bytes.resize(static_cast<std::size_t>(r.size));
  std::size_t done = 0;
  while (done < r.bytes.size()) {
    const ssize_t n = ::read(fd, r.bytes.data() + done, r.bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      r.error = n == 0 ? "the file shrank while being read" : std::strerror(errno);
      r.bytes.clear();
      return r;
    }
    done += static_cast<std::size_t>(n);
  }
  return r;
}

}  // namespace densemap::server
