// Small, strict text and file helpers every reader shares: whole-token numbers (so "1.5abc" is not 1.5
// and "nan" is reported as NaN, not as "not a number"), and reading a file with a size limit.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace densemap::io {

/// The whitespace-separated words of `text`.
std::vector<std::string_view> splitWords(std::string_view text);
/// `token` as a double when all of it is one ("nan" and "inf" included); nullopt otherwise.
std::optional<double> parseDouble(std::string_view token);
/// `token` as an unsigned integer when all of it is one (no sign, no overflow); nullopt otherwise.
std::optional<std::uint64_t> parseUnsigned(std::string_view token);
/// `token` as a signed integer when all of it is one (no overflow); nullopt otherwise.
std::optional<std::int64_t> parseSigned(std::string_view token);
/// The bytes of a regular file; throws SourceError naming it when it is missing, not a regular file,
/// larger than `max_bytes` or unreadable. `what` says what the file should be ("PCD file").
std::string readFileBytes(const std::string& path, std::size_t max_bytes, const std::string& what);

}  // namespace densemap::io
