#include "densemap/io/text_parse.h"

#include <charconv>
#include <cmath>
#include <fstream>
#include <system_error>

#include <sys/stat.h>

#include "densemap/io/scan.h"

namespace densemap::io {

std::vector<std::string_view> splitWords(std::string_view text) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  const auto space = [](char c) {
    return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\v' || c == '\f';
  };
  while (i < text.size()) {
    while (i < text.size() && space(text[i])) ++i;
    const std::size_t start = i;
    while (i < text.size() && !space(text[i])) ++i;
    if (i > start) out.push_back(text.substr(start, i - start));
  }
  return out;
}

std::optional<double> parseDouble(std::string_view token) {
  if (!token.empty() && token.front() == '+') token.remove_prefix(1);
  if (token.empty() || token.front() == '+') return std::nullopt;
  double v = 0;
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), v);
  // Out of range ("1e999") is still a number the caller reports as non-finite.
  if (ec == std::errc::result_out_of_range && end == token.data() + token.size())
    return token.front() == '-' ? -HUGE_VAL : HUGE_VAL;
  if (ec != std::errc() || end != token.data() + token.size()) return std::nullopt;
  return v;
}

std::optional<std::uint64_t> parseUnsigned(std::string_view token) {
  std::uint64_t v = 0;
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), v);
  if (token.empty() || ec != std::errc() || end != token.data() + token.size()) return std::nullopt;
  return v;
}

std::optional<std::int64_t> parseSigned(std::string_view token) {
  if (!token.empty() && token.front() == '+') token.remove_prefix(1);
  std::int64_t v = 0;
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), v);
  if (token.empty() || ec != std::errc() || end != token.data() + token.size()) return std::nullopt;
  return v;
}

std::string readFileBytes(const std::string& path, std::size_t max_bytes, const std::string& what) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) throw SourceError(path + ": no such " + what);
  if (!S_ISREG(st.st_mode)) throw SourceError(path + ": not a regular file (expected a " + what + ")");
  const auto size = static_cast<std::size_t>(st.st_size);
  if (size > max_bytes)
    throw SourceError(path + ": " + std::to_string(size) + " bytes, more than the " +
                      std::to_string(max_bytes) + " a " + what + " may have");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw SourceError(path + ": cannot open " + what);
  std::string bytes(size, '\0');
  if (!in.read(bytes.data(), static_cast<std::streamsize>(size)) ||
      in.gcount() != static_cast<std::streamsize>(size))
    throw SourceError(path + ": read failed (" + what + " changed while reading?)");
  return bytes;
}

}  // namespace densemap::io
