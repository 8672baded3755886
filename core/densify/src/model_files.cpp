#include "densemap/densify/model_files.h"

#include <filesystem>
#include <stdexcept>
#include <vector>

namespace densemap::densify {

std::string shippedWeights(const std::string& file) {
  namespace fs = std::filesystem;
  std::vector<fs::path> dirs{DENSEMAP_MODEL_DIR};
  std::error_code ec;
  // An installed program: <prefix>/bin/densemap-x and <prefix>/share/densemap/models.
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) dirs.push_back(exe.parent_path().parent_path() / "share/densemap/models");
  dirs.emplace_back("/opt/densemap/share/densemap/models");
  std::string looked;
  for (const fs::path& dir : dirs) {
    const fs::path p = dir / file;
    if (fs::exists(p, ec)) return p.string();
    looked += (looked.empty() ? "" : ", ") + dir.string();
  }
  throw std::runtime_error("no " + file + " in " + looked +
                           "; pass a weights file instead (--densify-weights, or the tool's --weights)");
}

}  // namespace densemap::densify
