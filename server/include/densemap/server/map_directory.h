// The one directory where the service saves and loads maps. A request names a file (NAME.bt or
// NAME.ot), never a path: absolute paths, '/', names starting with '.', and symbolic links are refused,
// and every file operation is relative to the directory's descriptor (openat with O_NOFOLLOW), so no
// name can lead outside it. A save goes to a temporary file renamed into place (never a half map).
#pragma once

#include <cstddef>
#include <filesystem>
#include <mutex>
#include <string>
#include <string_view>

namespace densemap::server {

class MapDirectory {
 public:
  /// The directory is created (mode 0750) by the first save, so a server that never saves leaves none.
  explicit MapDirectory(std::filesystem::path dir) : dir_(std::move(dir)) {}
  ~MapDirectory();
  MapDirectory(const MapDirectory&) = delete;
  MapDirectory& operator=(const MapDirectory&) = delete;

  /// Empty when `name` may be used; else why not (for the reply).
  static std::string checkName(std::string_view name);

  /// Writes the bytes as `name` (replacing an earlier save of that name). Throws RequestError.
  void write(std::string_view name, std::string_view bytes) const;
  /// The file's bytes; throws RequestError (kNotFound when missing, kInvalidArgument over max_bytes).
  std::string read(std::string_view name, std::size_t max_bytes) const;

  const std::filesystem::path& path() const { return dir_; }

 private:
  /// The directory's descriptor, opened on first use (created when `create`); throws RequestError.
  int descriptor(bool create) const;

  std::filesystem::path dir_;
  mutable std::mutex mutex_;
  mutable int fd_ = -1;
};

}  // namespace densemap::server
