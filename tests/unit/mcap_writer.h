// A small MCAP writer for tests and fuzz seeds: re-records messages with chunks uncompressed, lz4 or
// zstd, or with no chunks at all, so every path of the reader runs on real ROS 2 bytes.
#pragma once

#include <lz4frame.h>
#include <zlib.h>
#include <zstd.h>

#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

namespace densemap::test {

struct McapMessage {
  std::uint16_t channel = 0;
  std::uint64_t log_time = 0;
  std::vector<std::uint8_t> data;
};

struct McapChannel {
  std::uint16_t id = 0;
  std::string topic, type, qos;
};

class McapWriter {
 public:
  /// compression: "none" (no chunks), "" (uncompressed chunks), "lz4" or "zstd".
  explicit McapWriter(std::string compression, std::size_t messages_per_chunk = 4)
      : compression_(std::move(compression)), per_chunk_(messages_per_chunk) {}

  std::vector<std::uint8_t> write(const std::vector<McapChannel>& channels,
                                  const std::vector<McapMessage>& messages) {
    std::vector<std::uint8_t> out(kMagic, kMagic + 8);
    std::vector<std::uint8_t> header;
    str(header, "ros2");
    str(header, "densemap test");
    record(out, 0x01, header);
    std::vector<std::uint8_t> defs;
    for (const McapChannel& c : channels) {
      std::vector<std::uint8_t> schema;
      num<std::uint16_t>(schema, c.id + 1);
      str(schema, c.type);
      str(schema, "ros2msg");
      num<std::uint32_t>(schema, 0);
      record(defs, 0x03, schema);
      std::vector<std::uint8_t> channel;
      num<std::uint16_t>(channel, c.id);
      num<std::uint16_t>(channel, c.id + 1);
      str(channel, c.topic);
      str(channel, "cdr");
      std::vector<std::uint8_t> map;
      str(map, "offered_qos_profiles");
      str(map, c.qos);
      num<std::uint32_t>(channel, static_cast<std::uint32_t>(map.size()));
      channel.insert(channel.end(), map.begin(), map.end());
      record(defs, 0x04, channel);
    }
    out.insert(out.end(), defs.begin(), defs.end());
    std::vector<std::uint8_t> pending;
    std::size_t in_chunk = 0;
    std::uint64_t first = 0, last = 0;
    auto flush = [&] {
      if (pending.empty()) return;
      std::vector<std::uint8_t> chunk;
      num<std::uint64_t>(chunk, first);
      num<std::uint64_t>(chunk, last);
      num<std::uint64_t>(chunk, pending.size());
      num<std::uint32_t>(
          chunk, static_cast<std::uint32_t>(::crc32(0L, pending.data(), static_cast<uInt>(pending.size()))));
      str(chunk, compression_);
      const std::vector<std::uint8_t> packed = compress(pending);
      num<std::uint64_t>(chunk, packed.size());
      chunk.insert(chunk.end(), packed.begin(), packed.end());
      record(out, 0x06, chunk);
      pending.clear();
      in_chunk = 0;
    };
    for (const McapMessage& m : messages) {
      std::vector<std::uint8_t> body;
      num<std::uint16_t>(body, m.channel);
      num<std::uint32_t>(body, 0);
      num<std::uint64_t>(body, m.log_time);
      num<std::uint64_t>(body, m.log_time);
      body.insert(body.end(), m.data.begin(), m.data.end());
      if (compression_ == "none") {
        record(out, 0x05, body);
        continue;
      }
      if (in_chunk == 0) first = m.log_time;
      last = m.log_time;
      record(pending, 0x05, body);
      if (++in_chunk == per_chunk_) flush();
    }
    flush();
    std::vector<std::uint8_t> data_end;
    num<std::uint32_t>(data_end, 0);
    record(out, 0x0F, data_end);
    std::vector<std::uint8_t> footer;
    num<std::uint64_t>(footer, 0);
    num<std::uint64_t>(footer, 0);
    num<std::uint32_t>(footer, 0);
    record(out, 0x02, footer);
    out.insert(out.end(), kMagic, kMagic + 8);
    return out;
  }

 private:
  static constexpr std::uint8_t kMagic[8] = {0x89, 'M', 'C', 'A', 'P', 0x30, '\r', '\n'};
  template <typename T>
  static void num(std::vector<std::uint8_t>& b, T v) {
    const std::size_t at = b.size();
    b.resize(at + sizeof v);
    std::memcpy(b.data() + at, &v, sizeof v);
  }
  static void str(std::vector<std::uint8_t>& b, const std::string& s) {
    num<std::uint32_t>(b, static_cast<std::uint32_t>(s.size()));
    b.insert(b.end(), s.begin(), s.end());
  }
  static void record(std::vector<std::uint8_t>& b, std::uint8_t op, const std::vector<std::uint8_t>& body) {
    b.push_back(op);
    num<std::uint64_t>(b, body.size());
    b.insert(b.end(), body.begin(), body.end());
  }
  std::vector<std::uint8_t> compress(const std::vector<std::uint8_t>& in) const {
    if (compression_.empty()) return in;
    std::vector<std::uint8_t> out;
    if (compression_ == "zstd") {
      out.resize(ZSTD_compressBound(in.size()));
      out.resize(ZSTD_compress(out.data(), out.size(), in.data(), in.size(), 3));
    } else if (compression_ == "lz4") {
      out.resize(LZ4F_compressFrameBound(in.size(), nullptr));
      const std::size_t n = LZ4F_compressFrame(out.data(), out.size(), in.data(), in.size(), nullptr);
      if (LZ4F_isError(n)) throw std::runtime_error("lz4 compression failed");
      out.resize(n);
    } else {
      throw std::runtime_error("unknown compression " + compression_);
    }
    return out;
  }
  std::string compression_;
  std::size_t per_chunk_;
};

}  // namespace densemap::test
