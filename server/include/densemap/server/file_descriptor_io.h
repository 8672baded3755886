// Whole reads and writes on an open file descriptor, with EINTR retried: what the map directory and the
// block store both do before their own checks and messages. Neither closes the descriptor.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

namespace densemap::server {

/// What errno says now (strerror), for messages.
std::string errnoText();

/// Writes every byte; returns empty when done, else what went wrong (strerror).
std::string writeAll(int fd, std::string_view bytes);

struct RegularFileRead {
  std::string bytes;
  std::string error;       ///< empty when read; else what went wrong
  bool too_large = false;  ///< larger than the limit (error says so too); nothing was read
  std::uint64_t size = 0;  ///< the file's size
};
/// Reads a whole regular file of at most `max_bytes` (fstat first: a symbolic link opened with O_NOFOLLOW
/// never gets here; a directory or device is refused).
RegularFileRead readRegularFile(int fd, std::uint64_t max_bytes);

}  // namespace densemap::server
