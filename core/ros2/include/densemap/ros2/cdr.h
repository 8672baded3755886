// Plain CDR (XCDR1, what rmw_fastrtps writes for ROS 2 messages): a bounds-checked reader and a writer.
// Every ROS 2 sample starts with a 4-byte encapsulation header (0x00 0x01 = little endian); primitives are
// aligned to their size counted from the byte after that header, 8-byte types included (XCDR1 rule).
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

namespace densemap::ros2 {

/// A sample that cannot be read: the message says which field and why.
class DecodeError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class CdrReader {
 public:
  /// Reads the encapsulation header; throws DecodeError for a short buffer or an encapsulation that is not
  /// plain CDR (XCDR2 and parameter lists are not what ROS 2 sends).
  explicit CdrReader(std::span<const std::uint8_t> bytes);

  bool littleEndian() const { return little_; }
  std::size_t offset() const { return pos_; }
  std::size_t remaining() const { return body_.size() - pos_; }

  std::uint8_t u8(const char* field);
  bool boolean(const char* field);
  std::uint32_t u32(const char* field);
  std::int32_t i32(const char* field) { return static_cast<std::int32_t>(u32(field)); }
  std::uint64_t u64(const char* field);
  double f64(const char* field);
  float f32(const char* field);
  std::string string(const char* field);
  /// A sequence length, checked against what is left (each element at least `min_element_bytes`), so a
  /// huge claimed count fails before anything is allocated.
  std::uint32_t sequenceLength(const char* field, std::size_t min_element_bytes);
  /// A sequence<uint8>: a view into the sample (valid while the bytes are).
  std::span<const std::uint8_t> byteSequence(const char* field);
  /// Throws DecodeError unless the message ends here: nothing may follow but the padding that rounds the
  /// sample up to a multiple of 4 bytes (which Cyclone DDS adds and Fast DDS does not). A sample of the
  /// right type with bytes to spare is another layout (e.g. a request header this reader was not told of),
  /// never read as if they were not there.
  void expectEnd(const char* message);

 private:
  void align(std::size_t n);
  void need(std::size_t n, const char* field) const;
  template <typename T>
  T primitive(const char* field);

  std::span<const std::uint8_t> body_;  ///< after the encapsulation header
  std::size_t pos_ = 0;
  bool little_ = true;
};

/// Writes little-endian plain CDR with the encapsulation header, as rmw_fastrtps does.
class CdrWriter {
 public:
  CdrWriter();
  void u8(std::uint8_t v) { bytes_.push_back(v); }
  void boolean(bool v) { u8(v ? 1 : 0); }
  void u32(std::uint32_t v) { primitive(v); }
  void i32(std::int32_t v) { primitive(v); }
  void u64(std::uint64_t v) { primitive(v); }
  void f64(double v) { primitive(v); }
  void f32(float v) { primitive(v); }
  void string(const std::string& s);
  void byteSequence(std::span<const std::uint8_t> data);
  /// The sample, encapsulation header included.
  std::vector<std::uint8_t> finish();

 private:
  template <typename T>
  void primitive(T v) {
    align(sizeof(T));
    const std::size_t at = bytes_.size();
    bytes_.resize(at + sizeof(T));
    std::memcpy(bytes_.data() + at, &v, sizeof(T));
  }
  void align(std::size_t n);
  std::vector<std::uint8_t> bytes_;
};

}  // namespace densemap::ros2
