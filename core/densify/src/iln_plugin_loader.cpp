#include <dlfcn.h>

#include <array>
#include <cstdlib>
#include <filesystem>
#include <mutex>
#include <stdexcept>
#include <vector>

#include "densemap/densify/iln_plugin.h"

namespace densemap::densify {

namespace {

/// The plugin's factory, found once: $DENSEMAP_PLUGIN_DIR, the build tree, then <prefix>/lib/densemap
/// beside an installed program. The library is never closed: upsamplers it made keep using its code.
IlnFactory factory() {
  static std::mutex mutex;
  static IlnFactory found = nullptr;
  std::lock_guard lock(mutex);
  if (found != nullptr) return found;
  namespace fs = std::filesystem;
  std::vector<fs::path> dirs;
  if (const char* env = std::getenv("DENSEMAP_PLUGIN_DIR")) dirs.emplace_back(env);
  dirs.emplace_back(DENSEMAP_PLUGIN_BUILD_DIR);
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) dirs.push_back(exe.parent_path().parent_path() / "lib/densemap");
  std::string tried;
  for (const fs::path& dir : dirs) {
    const fs::path lib = dir / kIlnPluginFile;
    if (!fs::exists(lib, ec)) {
      tried += (tried.empty() ? "" : ", ") + dir.string();
      continue;
    }
    void* handle = ::dlopen(lib.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (handle == nullptr) throw std::runtime_error("cannot load " + lib.string() + ": " + ::dlerror());
    found = reinterpret_cast<IlnFactory>(::dlsym(handle, kIlnFactorySymbol));
    if (found == nullptr) throw std::runtime_error(lib.string() + " has no " + kIlnFactorySymbol);
    return found;
  }
  throw std::runtime_error(std::string("--densify iln needs ") + kIlnPluginFile +
                           " (built with densemap); not in " + tried +
                           " (set DENSEMAP_PLUGIN_DIR to its directory)");
}

}  // namespace

std::unique_ptr<RangeUpsampler> loadIlnUpsampler(const std::string& weights, int threads) {
  std::array<char, 512> error{};
  std::unique_ptr<RangeUpsampler> up(factory()(weights.c_str(), threads, error.data(), error.size()));
  if (!up) throw std::runtime_error(error.data());
  return up;
}

}  // namespace densemap::densify
