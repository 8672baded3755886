#include "densemap/ros2/cdr.h"

#include <bit>

namespace densemap::ros2 {

static_assert(std::endian::native == std::endian::little, "the CDR codec assumes a little-endian host");

CdrReader::CdrReader(std::span<const std::uint8_t> bytes) {
  if (bytes.size() < 4)
    throw DecodeError("sample of " + std::to_string(bytes.size()) + " bytes has no CDR encapsulation header");
  if (bytes[0] != 0x00 || (bytes[1] != 0x00 && bytes[1] != 0x01))
    throw DecodeError("encapsulation " + std::to_string(bytes[0]) + "," + std::to_string(bytes[1]) +
                      " is not plain CDR (ROS 2 sends 0,1 = CDR little endian)");
  little_ = bytes[1] == 0x01;
  body_ = bytes.subspan(4);
}

void CdrReader::align(std::size_t n) {
  const std::size_t pad = (n - pos_ % n) % n;
  pos_ = pos_ + pad > body_.size() ? body_.size() + 1 : pos_ + pad;  // past the end: the next need() fails
}

void CdrReader::need(std::size_t n, const char* field) const {
  if (pos_ > body_.size() || body_.size() - pos_ < n)
    throw DecodeError(std::string("sample ends inside field '") + field + "' (at byte " +
                      std::to_string(pos_ + 4) + " of " + std::to_string(body_.size() + 4) + ")");
}

template <typename T>
T CdrReader::primitive(const char* field) {
  align(sizeof(T));
  need(sizeof(T), field);
  T v;
  std::memcpy(&v, body_.data() + pos_, sizeof(T));
  pos_ += sizeof(T);
  if (!little_) {
    auto* b = reinterpret_cast<unsigned char*>(&v);
    for (std::size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(b[i], b[sizeof(T) - 1 - i]);
  }
  return v;
}

std::uint8_t CdrReader::u8(const char* field) { return primitive<std::uint8_t>(field); }

bool CdrReader::boolean(const char* field) {
  const std::uint8_t v = u8(field);
  if (v > 1) throw DecodeError(std::string("field '") + field + "' is a bool holding " + std::to_string(v));
  return v == 1;
}

std::uint32_t CdrReader::u32(const char* field) { return primitive<std::uint32_t>(field); }
std::uint64_t CdrReader::u64(const char* field) { return primitive<std::uint64_t>(field); }
double CdrReader::f64(const char* field) { return primitive<double>(field); }
float CdrReader::f32(const char* field) { return primitive<float>(field); }

std::string CdrReader::string(const char* field) {
  const std::uint32_t length = u32(field);  // counts the terminating NUL
  need(length, field);
  if (length == 0) return {};  // some writers send an empty string as length 0
  const auto* begin = reinterpret_cast<const char*>(body_.data() + pos_);
  if (begin[length - 1] != '\0') throw DecodeError(std::string("string '") + field + "' is not terminated");
  std::string s(begin, length - 1);
  if (s.find('\0') != std::string::npos)
    throw DecodeError(std::string("string '") + field + "' holds a NUL byte");
  pos_ += length;
  return s;
}

std::uint32_t CdrReader::sequenceLength(const char* field, std::size_t min_element_bytes) {
  const std::uint32_t n = u32(field);
  if (min_element_bytes > 0 && n > remaining() / min_element_bytes)
    throw DecodeError(std::string("sequence '") + field + "' claims " + std::to_string(n) +
                      " elements but only " + std::to_string(remaining()) + " bytes follow");
  return n;
}

std::span<const std::uint8_t> CdrReader::byteSequence(const char* field) {
  const std::uint32_t n = sequenceLength(field, 1);
  auto view = body_.subspan(pos_, n);
  pos_ += n;
  return view;
}

void CdrReader::expectEnd(const char* message) {
  const std::size_t left = pos_ > body_.size() ? 0 : body_.size() - pos_;
  if (left == 0 || (left < 4 && body_.size() % 4 == 0)) return;
  throw DecodeError(std::string(message) + ": " + std::to_string(left) +
                    " bytes follow its last field (at byte " + std::to_string(pos_ + 4) + " of " +
                    std::to_string(body_.size() + 4) + ")");
}

CdrWriter::CdrWriter() : bytes_{0x00, 0x01, 0x00, 0x00} {}

void CdrWriter::align(std::size_t n) {
  const std::size_t body = bytes_.size() - 4;
  bytes_.resize(bytes_.size() + (n - body % n) % n, 0);
}

void CdrWriter::string(const std::string& s) {
  u32(static_cast<std::uint32_t>(s.size() + 1));
  bytes_.insert(bytes_.end(), s.begin(), s.end());
  bytes_.push_back(0);
}

void CdrWriter::byteSequence(std::span<const std::uint8_t> data) {
  u32(static_cast<std::uint32_t>(data.size()));
  bytes_.insert(bytes_.end(), data.begin(), data.end());
}

std::vector<std::uint8_t> CdrWriter::finish() { return std::move(bytes_); }

}  // namespace densemap::ros2
