// Little-endian fixed-width fields for densemap's own binary files (the journal, snapshots, the dense
// layer's state): a writer that appends to a string and a bounds-checked reader whose errors name the
// field and the offset, so a damaged file is reported where it is damaged.
#pragma once

#include <bit>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <string_view>
#include <type_traits>

namespace densemap::util {

static_assert(std::endian::native == std::endian::little, "densemap's files are written little endian");

/// Bytes that do not decode: what() names the field and the offset.
class FormatError : public std::runtime_error {
 public:
  FormatError(const std::string& what, std::size_t offset)
      : std::runtime_error(what + " at offset " + std::to_string(offset)), offset_(offset) {}
  std::size_t offset() const { return offset_; }

 private:
  std::size_t offset_;
};

class ByteWriter {
 public:
  explicit ByteWriter(std::string& out) : out_(out) {}
  template <class T>
  void put(T v) {
    static_assert(std::is_arithmetic_v<T>);
    out_.append(reinterpret_cast<const char*>(&v), sizeof v);
  }
  void bytes(const void* data, std::size_t n) { out_.append(static_cast<const char*>(data), n); }
  /// A u32 length, then the bytes.
  void string(std::string_view s) {
    put(static_cast<std::uint32_t>(s.size()));
    out_.append(s);
  }
  std::size_t size() const { return out_.size(); }

 private:
  std::string& out_;
};

class ByteReader {
 public:
  /// `base` is added to offsets in errors (where these bytes start in their file).
  explicit ByteReader(std::string_view bytes, std::size_t base = 0) : bytes_(bytes), base_(base) {}
  template <class T>
  T get(const char* field) {
    static_assert(std::is_arithmetic_v<T>);
    T v;
    std::memcpy(&v, take(sizeof v, field), sizeof v);
    return v;
  }
  /// `n` bytes, checked against what is left.
  const char* take(std::size_t n, const char* field) {
    if (n > bytes_.size() - pos_)
      throw FormatError(std::string(field) + ": needs " + std::to_string(n) + " bytes, " +
                            std::to_string(bytes_.size() - pos_) + " left",
                        base_ + pos_);
    const char* p = bytes_.data() + pos_;
    pos_ += n;
    return p;
  }
  /// A u32 length (at most `max`), then the bytes.
  std::string string(const char* field, std::size_t max = 1 << 20) {
    const auto n = get<std::uint32_t>(field);
    if (n > max)
      throw FormatError(
          std::string(field) + ": length " + std::to_string(n) + " is over " + std::to_string(max),
          base_ + pos_ - 4);
    return std::string(take(n, field), n);
  }
  /// A count of elements of at least `element_bytes` each, checked against what is left, so a huge
  /// claimed count fails here instead of in an allocation.
  std::uint64_t count(const char* field, std::size_t element_bytes) {
    const auto n = get<std::uint64_t>(field);
    if (element_bytes > 0 && n > remaining() / element_bytes)
      throw FormatError(std::string(field) + ": " + std::to_string(n) + " elements do not fit in the " +
                            std::to_string(remaining()) + " bytes left",
                        base_ + pos_ - 8);
    return n;
  }
  std::size_t offset() const { return base_ + pos_; }
  std::size_t remaining() const { return bytes_.size() - pos_; }
  bool done() const { return pos_ == bytes_.size(); }
  [[noreturn]] void fail(const std::string& what) const { throw FormatError(what, base_ + pos_); }

 private:
  std::string_view bytes_;
  std::size_t pos_ = 0;
  std::size_t base_ = 0;
};

}  // namespace densemap::util
