// PCD v0.7 (https://pointclouds.org/documentation/tutorials/pcd_file_format.html), our own parser. Every
// count is checked against the bytes that are there before anything is allocated, and a field is either
// read exactly or the file is rejected with the field's name.
#include "densemap/io/pcd_file.h"

#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <optional>

#include <fmt/format.h>
#include <lzf.h>

#include "densemap/io/text_parse.h"

namespace densemap::io {

namespace {

/// 4 GiB: the largest file binary_compressed can describe (32-bit sizes); we read none larger.
constexpr std::size_t kMaxPcdBytes = std::size_t{1} << 32;
/// Headers are a few hundred bytes; a "header" without DATA in the first 64 KiB is not a PCD.
constexpr std::size_t kMaxHeaderBytes = 64 * 1024;
/// LZF turns at most 3 input bytes into 264 output bytes; a claimed size beyond that is a lie.
constexpr std::size_t kMaxLzfRatio = 88;

enum class DataKind { kAscii, kBinary, kBinaryCompressed };

struct Field {
  std::string name;
  std::size_t size = 0;  // bytes per element
  char type = 0;         // F, U or I
  std::size_t count = 1;
  std::size_t offset = 0;  // within a point (binary)
};

struct Header {
  std::vector<Field> fields;
  std::size_t width = 0, height = 0, points = 0, point_step = 0;
  double viewpoint[7] = {0, 0, 0, 1, 0, 0, 0};
  DataKind kind = DataKind::kBinary;
  std::size_t data_offset = 0;  // first byte after the DATA line
};

class PcdParser {
 public:
  PcdParser(std::string_view bytes, const std::string& name) : bytes_(bytes), name_(name) {}

  PcdData parse() {
    if (bytes_.empty()) fail("the file is empty (0 bytes); expected a PCD header");
    parseHeader();
    PcdData out;
    const Field* xyz[3] = {&field("x"), &field("y"), &field("z")};
    switch (h_.kind) {
      case DataKind::kAscii:
        readAscii(xyz, out);
        break;
      case DataKind::kBinary:
        readBinary(xyz, out);
        break;
      case DataKind::kBinaryCompressed:
        readCompressed(xyz, out);
        break;
    }
    const double* v = h_.viewpoint;
    Eigen::Quaterniond q(v[3], v[4], v[5], v[6]);
    out.viewpoint = Eigen::Vector3d(v[0], v[1], v[2]);
    if (!out.viewpoint.allFinite() || !std::isfinite(q.norm()))
      fail(fmt::format("VIEWPOINT {} {} {} {} {} {} {} is not finite", v[0], v[1], v[2], v[3], v[4], v[5],
                       v[6]));
    if (std::abs(q.norm() - 1.0) > 1e-3)
      fail(fmt::format("VIEWPOINT quaternion ({} {} {} {}) has norm {:.6g}; expected a unit quaternion", v[3],
                       v[4], v[5], v[6], q.norm()));
    out.viewpoint_orientation = q.normalized();
    return out;
  }

 private:
  [[noreturn]] void fail(const std::string& what) const { throw SourceError(name_ + ": " + what); }

  const Field& field(const std::string& n) const {
    const Field* found = nullptr;
    for (const auto& f : h_.fields)
      if (f.name == n) {
        if (found) fail("field '" + n + "' appears twice in FIELDS");
        found = &f;
      }
    if (!found) fail("FIELDS has no '" + n + "'; densemap needs x y z");
    if (found->type != 'F' || (found->size != 4 && found->size != 8))
      fail(fmt::format(
          "field '{}' is TYPE {} SIZE {}; coordinates must be TYPE F SIZE 4 or 8 (float32 or float64)", n,
          found->type, found->size));
    if (found->count != 1)
      fail(fmt::format("field '{}' has COUNT {}; a coordinate has COUNT 1", n, found->count));
    return *found;
  }

  std::size_t count(std::string_view key, std::string_view word, std::size_t max) const {
    const auto v = parseUnsigned(word);
    if (!v || *v > max) fail(fmt::format("{} '{}' is not a whole number in 0..{}", key, word, max));
    return static_cast<std::size_t>(*v);
  }

  void parseHeader() {
    std::size_t pos = 0;
    bool seen_data = false, seen_points = false, seen_width = false, seen_height = false;
    std::vector<std::string_view> names, sizes, types, counts;
    bool seen_count = false;
    while (!seen_data) {
      if (pos >= bytes_.size())
        fail("the header ends before its DATA line (file cut short, or not a PCD file)");
      if (pos > kMaxHeaderBytes) fail("no DATA line in the first 64 KiB; not a PCD file");
      auto eol = bytes_.find('\n', pos);
      if (eol == std::string_view::npos) eol = bytes_.size();
      const std::string_view line = bytes_.substr(pos, eol - pos);
      const std::size_t line_start = pos;
      pos = eol + 1;
      for (char c : line)
        if (static_cast<unsigned char>(c) < 0x09 || static_cast<unsigned char>(c) > 0x7e)
          fail(fmt::format("byte {} of the header is not text; not a PCD file (or DATA line missing)",
                           line_start));
      auto words = splitWords(line);
      if (words.empty() || words[0].front() == '#') continue;
      const std::string_view key = words[0];
      words.erase(words.begin());
      auto once = [&](bool& seen) {
        if (seen) fail(fmt::format("header has two {} lines", key));
        seen = true;
      };
      if (key == "VERSION") {
        if (words.size() != 1 || (words[0] != ".7" && words[0] != "0.7"))
          fail("VERSION must be 0.7 (the only version densemap reads)");
      } else if (key == "FIELDS") {
        names = words;
      } else if (key == "SIZE") {
        sizes = words;
      } else if (key == "TYPE") {
        types = words;
      } else if (key == "COUNT") {
        counts = words;
        once(seen_count);
      } else if (key == "WIDTH") {
        once(seen_width);
        if (words.size() != 1) fail("WIDTH needs one number");
        h_.width = count("WIDTH", words[0], std::numeric_limits<std::uint32_t>::max());
      } else if (key == "HEIGHT") {
        once(seen_height);
        if (words.size() != 1) fail("HEIGHT needs one number");
        h_.height = count("HEIGHT", words[0], std::numeric_limits<std::uint32_t>::max());
      } else if (key == "POINTS") {
        once(seen_points);
        if (words.size() != 1) fail("POINTS needs one number");
        h_.points = count("POINTS", words[0], std::numeric_limits<std::uint32_t>::max());
      } else if (key == "VIEWPOINT") {
        if (words.size() != 7)
          fail(fmt::format("VIEWPOINT has {} values; expected 7 (tx ty tz qw qx qy qz)", words.size()));
        for (int i = 0; i < 7; ++i) {
          const auto v = parseDouble(words[static_cast<std::size_t>(i)]);
          if (!v)
            fail(fmt::format("VIEWPOINT value '{}' is not a number", words[static_cast<std::size_t>(i)]));
          h_.viewpoint[i] = *v;
        }
      } else if (key == "DATA") {
        if (words.size() != 1) fail("DATA needs one of ascii, binary, binary_compressed");
        if (words[0] == "ascii")
          h_.kind = DataKind::kAscii;
        else if (words[0] == "binary")
          h_.kind = DataKind::kBinary;
        else if (words[0] == "binary_compressed")
          h_.kind = DataKind::kBinaryCompressed;
        else
          fail(fmt::format("DATA '{}' is not ascii, binary or binary_compressed", words[0]));
        seen_data = true;
        h_.data_offset = std::min(pos, bytes_.size());
      } else {
        fail(fmt::format("unknown header line '{}'", key.substr(0, 40)));
      }
    }
    if (names.empty()) fail("header has no FIELDS line");
    if (sizes.size() != names.size() || types.size() != names.size())
      fail(fmt::format("FIELDS lists {} fields but SIZE has {} and TYPE {} values", names.size(),
                       sizes.size(), types.size()));
    if (seen_count && counts.size() != names.size())
      fail(fmt::format("FIELDS lists {} fields but COUNT has {} values", names.size(), counts.size()));
    if (!seen_width) fail("header has no WIDTH line");
    if (!seen_height) h_.height = 1;
    if (h_.width != 0 && h_.height > std::numeric_limits<std::uint32_t>::max() / h_.width)
      fail(fmt::format("WIDTH {} x HEIGHT {} overflows", h_.width, h_.height));
    if (!seen_points) h_.points = h_.width * h_.height;
    if (h_.points != h_.width * h_.height)
      fail(fmt::format("POINTS {} differs from WIDTH {} x HEIGHT {}", h_.points, h_.width, h_.height));
    for (std::size_t i = 0; i < names.size(); ++i) {
      Field f;
      f.name = std::string(names[i]);
      f.size = count("SIZE", sizes[i], 8);
      if (f.size != 1 && f.size != 2 && f.size != 4 && f.size != 8)
        fail(fmt::format("SIZE of field '{}' is {}; expected 1, 2, 4 or 8", f.name, f.size));
      if (types[i].size() != 1 || std::string_view("FUI").find(types[i][0]) == std::string_view::npos)
        fail(fmt::format("TYPE of field '{}' is '{}'; expected F, U or I", f.name, types[i]));
      f.type = types[i][0];
      if (f.type == 'F' && f.size != 4 && f.size != 8)
        fail(fmt::format("field '{}' is TYPE F SIZE {}; floats are SIZE 4 or 8", f.name, f.size));
      if (seen_count) {
        const auto c = parseSigned(counts[i]);
        if (!c || *c < 1 || *c > 1'000'000)
          fail(fmt::format("COUNT of field '{}' is '{}'; expected a whole number in 1..1000000", f.name,
                           counts[i]));
        f.count = static_cast<std::size_t>(*c);
      }
      f.offset = h_.point_step;
      h_.point_step += f.size * f.count;
      h_.fields.push_back(f);
    }
  }

  std::size_t dataBytes() const { return bytes_.size() - h_.data_offset; }

  /// Float coordinate at `p` (SIZE 4 or 8), widened to double.
  static double coordinate(const char* p, std::size_t size) {
    if (size == 4) {
      float f;
      std::memcpy(&f, p, 4);
      return f;
    }
    double d;
    std::memcpy(&d, p, 8);
    return d;
  }

  void add(PcdData& out, double x, double y, double z) const {
    const Vec3f p(static_cast<float>(x), static_cast<float>(y), static_cast<float>(z));
    if (p.allFinite())
      out.points.push_back(p);
    else
      ++out.nonfinite_points;
  }

  void checkLength(std::size_t need, std::size_t have, const char* what) const {
    if (have < need)
      fail(
          fmt::format("{} POINTS of {} bytes need {} bytes of {} data but the file has {} after the header "
                      "(truncated, or a header claiming more than is there)",
                      h_.points, h_.point_step, need, what, have));
    // Some PCL versions pad binary files with zeros; anything else past the data means the header does
    // not describe it.
    const std::string_view rest = bytes_.substr(bytes_.size() - (have - need));
    if (rest.find_first_not_of('\0') != std::string_view::npos)
      fail(fmt::format(
          "{} bytes that are not zero padding follow the {} data of {} POINTS ({} bytes); the header "
          "does not describe this data",
          rest.size(), what, h_.points, need));
  }

  void readBinary(const Field* const xyz[3], PcdData& out) {
    // POINTS <= 2^32 and point_step <= 8e6 x fields: the product fits in 64 bits.
    const std::size_t need = h_.points * h_.point_step;
    checkLength(need, dataBytes(), "binary");
    out.points.reserve(h_.points);
    const char* base = bytes_.data() + h_.data_offset;
    for (std::size_t i = 0; i < h_.points; ++i) {
      const char* p = base + i * h_.point_step;
      add(out, coordinate(p + xyz[0]->offset, xyz[0]->size), coordinate(p + xyz[1]->offset, xyz[1]->size),
          coordinate(p + xyz[2]->offset, xyz[2]->size));
    }
  }

  void readCompressed(const Field* const xyz[3], PcdData& out) {
    if (dataBytes() < 8)
      fail("binary_compressed data needs 8 bytes of sizes after the header; the file ends");
    std::uint32_t compressed = 0, uncompressed = 0;
    std::memcpy(&compressed, bytes_.data() + h_.data_offset, 4);
    std::memcpy(&uncompressed, bytes_.data() + h_.data_offset + 4, 4);
    const std::size_t need = h_.points * h_.point_step;
    if (uncompressed != need)
      fail(fmt::format("binary_compressed data claims {} bytes uncompressed; {} POINTS of {} bytes are {}",
                       uncompressed, h_.points, h_.point_step, need));
    checkLength(compressed, dataBytes() - 8, "compressed");
    if (need > std::size_t{compressed} * kMaxLzfRatio + 16)
      fail(fmt::format(
          "binary_compressed data claims {} bytes from {} compressed bytes; LZF cannot expand that "
          "much",
          need, compressed));
    std::vector<char> soa(need);
    if (need > 0) {
      const unsigned got = lzf_decompress(bytes_.data() + h_.data_offset + 8, compressed, soa.data(),
                                          static_cast<unsigned>(need));
      if (got != need)
        fail(fmt::format("binary_compressed data is corrupt: LZF gave {} of {} bytes", got, need));
    }
    // Decompressed data holds the fields one after another (all x, then all y, ...).
    out.points.reserve(h_.points);
    for (std::size_t i = 0; i < h_.points; ++i) {
      double c[3];
      for (int k = 0; k < 3; ++k)
        c[k] = coordinate(soa.data() + h_.points * xyz[k]->offset + i * xyz[k]->size, xyz[k]->size);
      add(out, c[0], c[1], c[2]);
    }
  }

  void readAscii(const Field* const xyz[3], PcdData& out) {
    std::size_t values = 0;
    for (const auto& f : h_.fields) values += f.count;
    // Each value takes at least a digit and a separator.
    if (h_.points > dataBytes() / (2 * values) + 1)
      fail(fmt::format("{} POINTS of {} values cannot fit in the {} bytes after the header (truncated?)",
                       h_.points, values, dataBytes()));
    out.points.reserve(h_.points);
    std::size_t pos = h_.data_offset, line_no = 0, read = 0;
    const std::size_t ix = xyz[0] - h_.fields.data(), iy = xyz[1] - h_.fields.data(),
                      iz = xyz[2] - h_.fields.data();
    while (pos < bytes_.size()) {
      auto eol = bytes_.find('\n', pos);
      if (eol == std::string_view::npos) eol = bytes_.size();
      const auto words = splitWords(bytes_.substr(pos, eol - pos));
      pos = eol + 1;
      ++line_no;
      if (words.empty()) continue;
      if (read == h_.points)
        fail(fmt::format("ascii data line {} is past the {} POINTS the header declares", line_no, h_.points));
      if (words.size() != values)
        fail(fmt::format("ascii data line {} has {} values; the fields need {}", line_no, words.size(),
                         values));
      double c[3] = {0, 0, 0};
      std::size_t w = 0;
      for (std::size_t fi = 0; fi < h_.fields.size(); ++fi) {
        const Field& f = h_.fields[fi];
        for (std::size_t k = 0; k < f.count; ++k, ++w) {
          const bool ok = f.type == 'F'   ? parseDouble(words[w]).has_value()
                          : f.type == 'U' ? parseUnsigned(words[w]).has_value()
                                          : parseSigned(words[w]).has_value();
          if (!ok)
            fail(fmt::format("ascii data line {}: '{}' is not a valid {} value for field '{}'", line_no,
                             words[w].substr(0, 40), f.type == 'F' ? "float" : "integer", f.name));
        }
        if (fi == ix || fi == iy || fi == iz) c[fi == ix ? 0 : fi == iy ? 1 : 2] = *parseDouble(words[w - 1]);
      }
      add(out, c[0], c[1], c[2]);
      ++read;
    }
    if (read != h_.points)
      fail(fmt::format("ascii data has {} points; the header declares {} (truncated?)", read, h_.points));
  }

  std::string_view bytes_;
  const std::string& name_;
  Header h_;
};

}  // namespace

PcdData parsePcd(std::string_view bytes, const std::string& name) { return PcdParser(bytes, name).parse(); }

PcdData readPcd(const std::string& path) {
  return parsePcd(readFileBytes(path, kMaxPcdBytes, "PCD file"), path);
}

void writePcd(const std::string& path, const std::vector<Vec3f>& points, const Eigen::Vector3d& viewpoint) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw SourceError(path + ": cannot write PCD file");
  out << fmt::format(
      "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\n"
      "COUNT 1 1 1\nWIDTH {}\nHEIGHT 1\nVIEWPOINT {} {} {} 1 0 0 0\nPOINTS {}\nDATA binary\n",
      points.size(), viewpoint.x(), viewpoint.y(), viewpoint.z(), points.size());
  for (const auto& p : points) out.write(reinterpret_cast<const char*>(p.data()), 3 * sizeof(float));
  if (!out.flush()) throw SourceError(path + ": cannot write PCD file (disk full?)");
}

}  // namespace densemap::io
