// libFuzzer target for the identity folder check (idl/src/dds_security.cpp, --security-dir): whatever the
// files hold (certificate, key, CAs, revocation list, signed governance and permissions, parsed by
// OpenSSL), the check returns an identity or throws DdsError, never crashes. The input is the folder's
// files in kSecurityFiles order, then crl.pem, separated by "\n=====\n" (seeds: a real folder's files).
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>

#include "densemap/msg/dds_node.h"
#include "densemap/msg/dds_security.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  namespace fs = std::filesystem;
  static const fs::path dir =
      fs::temp_directory_path() / ("densemap-fuzz-identity-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::string_view in(reinterpret_cast<const char*>(data), size);
  constexpr std::string_view kSeparator = "\n=====\n";
  std::size_t part = 0;
  const std::size_t files = std::size(densemap::msg::kSecurityFiles);
  while (part <= files) {
    const std::size_t end = in.find(kSeparator);
    const std::string name = part < files ? densemap::msg::kSecurityFiles[part] : "crl.pem";
    std::ofstream(dir / name, std::ios::binary) << in.substr(0, end);
    ++part;
    if (end == std::string_view::npos) break;
    in.remove_prefix(end + kSeparator.size());
  }
  try {
    const auto id = densemap::msg::checkSecurityFolder(dir.string());
    if (id.name.empty()) __builtin_trap();  // an accepted identity always has its name
  } catch (const densemap::msg::DdsError&) {
  }
  return 0;
}
