#include "densemap/io/numbered_files.h"

#include <algorithm>
#include <filesystem>

#include <fmt/format.h>

#include "densemap/io/scan.h"

namespace densemap::io {

namespace fs = std::filesystem;

std::optional<NumberedName> parseNumberedName(std::string_view name, std::string_view suffix) {
  if (name.size() <= suffix.size() || name.substr(name.size() - suffix.size()) != suffix) return std::nullopt;
  const std::string_view base = name.substr(0, name.size() - suffix.size());
  std::size_t digits = 0;
  while (digits < base.size() && base[base.size() - 1 - digits] >= '0' &&
         base[base.size() - 1 - digits] <= '9')
    ++digits;
  if (digits == 0) return std::nullopt;
  const std::string_view number = base.substr(base.size() - digits);
  const std::size_t first = number.find_first_not_of('0');
  // 18 significant digits always fit in 64 bits; a scan number that long is not a scan number.
  if (first != std::string_view::npos && digits - first > 18)
    throw SourceError(fmt::format("{}: scan number {}... has {} digits; at most 18 are read", name,
                                  number.substr(0, 24), digits - first));
  NumberedName out;
  out.stem = std::string(base.substr(0, base.size() - digits));
  for (char c : number) out.number = out.number * 10 + static_cast<std::uint64_t>(c - '0');
  return out;
}

std::vector<NumberedFile> listNumberedFiles(const std::string& dir, std::string_view suffix,
                                            bool allow_gaps) {
  std::vector<NumberedFile> files;
  std::optional<std::string> stem;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    const std::string name = e.path().filename().string();
    const auto parsed = parseNumberedName(name, suffix);
    if (!parsed) continue;
    if (stem && *stem != parsed->stem)
      throw SourceError(
          fmt::format("{}: holds scans named '{}<k>{}' and '{}<k>{}'; one sequence per directory", dir, *stem,
                      suffix, parsed->stem, suffix));
    stem = parsed->stem;
    files.push_back({parsed->number, e.path().string()});
  }
  if (ec) throw SourceError(dir + ": cannot list directory (" + ec.message() + ")");
  if (files.empty()) throw SourceError(fmt::format("{}: no numbered <name><k>{} files", dir, suffix));
  std::sort(files.begin(), files.end(), [](const auto& a, const auto& b) { return a.number < b.number; });
  for (std::size_t i = 1; i < files.size(); ++i) {
    if (files[i].number == files[i - 1].number)
      throw SourceError(fmt::format("{}: scan {} appears twice ({} and {})", dir, files[i].number,
                                    files[i - 1].path, files[i].path));
    if (files[i].number != files[i - 1].number + 1 && !allow_gaps)
      throw SourceError(
          fmt::format("{}: scan {} is missing (scans {}..{} found, {} files): a gap in the sequence. Restore "
                      "the file, or "
                      "pass --allow-gaps to map only the scans that are there",
                      dir, files[i - 1].number + 1, files.front().number, files.back().number, files.size()));
  }
  return files;
}

}  // namespace densemap::io
