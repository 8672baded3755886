#include "densemap/ros2/mcap_reader.h"

#include <fcntl.h>
#include <lz4frame.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>
#include <zstd.h>

#include <algorithm>
#include <cstring>

namespace densemap::ros2 {

namespace {

constexpr std::uint8_t kMagic[8] = {0x89, 'M', 'C', 'A', 'P', 0x30, '\r', '\n'};
enum Opcode : std::uint8_t {
  kHeader = 0x01,
  kFooter = 0x02,
  kSchema = 0x03,
  kChannel = 0x04,
  kMessage = 0x05,
  kChunk = 0x06,
  kDataEnd = 0x0F
};
// A chunk may not claim more than this, nor more than kMaxRatio times its compressed size: a hostile
// header must not make us allocate gigabytes (real ROS 2 chunks are a few MB, ratios below 20).
constexpr std::uint64_t kMaxChunkBytes = 1ull << 31;
constexpr std::uint64_t kMaxRatio = 1024;
constexpr int kChunkShift = 40;  // locator = (chunk + 1) << 40 | offset

/// Little-endian fields of one record, bounds-checked; errors give the absolute offset.
class Fields {
 public:
  Fields(std::span<const std::uint8_t> bytes, std::uint64_t base, const std::string& name, const char* record)
      : b_(bytes), base_(base), name_(name), record_(record) {}
  template <typename T>
  T get(const char* field) {
    need(sizeof(T), field);
    T v;
    std::memcpy(&v, b_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return v;
  }
  std::string string(const char* field) {
    const auto n = get<std::uint32_t>(field);
    need(n, field);
    std::string s(reinterpret_cast<const char*>(b_.data() + pos_), n);
    pos_ += n;
    return s;
  }
  std::span<const std::uint8_t> bytes(std::uint64_t n, const char* field) {
    need(n, field);
    auto v = b_.subspan(pos_, n);
    pos_ += n;
    return v;
  }
  std::span<const std::uint8_t> rest() { return b_.subspan(pos_); }
  std::uint64_t at() const { return base_ + pos_; }

 private:
  void need(std::uint64_t n, const char* field) const {
    if (b_.size() - pos_ < n)
      throw BagError(name_ + ": MCAP " + record_ + " record at offset " + std::to_string(base_) +
                     " ends inside its field '" + field + "'");
  }
  std::span<const std::uint8_t> b_;
  std::size_t pos_ = 0;
  std::uint64_t base_;
  const std::string& name_;
  const char* record_;
};

}  // namespace

McapReader::McapReader(const std::string& path) : name_(path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw BagError(path + ": cannot open (" + std::strerror(errno) + ")");
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    throw BagError(path + ": not a regular file");
  }
  const auto size = static_cast<std::size_t>(st.st_size);
  if (size > 0) {
    void* p = ::mmap(nullptr, size, PROT_READ, MAP_PRIVATE, fd, 0);
    ::close(fd);
    if (p == MAP_FAILED) throw BagError(path + ": cannot map (" + std::strerror(errno) + ")");
    mapping_ =
        std::shared_ptr<const void>(p, [size](const void* q) { ::munmap(const_cast<void*>(q), size); });
    bytes_ = {static_cast<const std::uint8_t*>(p), size};
  } else {
    ::close(fd);
  }
  index();
}

McapReader::McapReader(std::vector<std::uint8_t> bytes, std::string name)
    : name_(std::move(name)), owned_(std::move(bytes)), bytes_(owned_) {
  index();
}

void McapReader::index() {
  if (bytes_.size() < 2 * sizeof kMagic || std::memcmp(bytes_.data(), kMagic, sizeof kMagic) != 0)
    throw BagError(name_ + ": not an MCAP file (no MCAP magic at the start)");
  std::uint64_t pos = sizeof kMagic;
  bool ended = false;
  while (!ended && pos < bytes_.size()) {
    if (bytes_.size() - pos < 9)
      throw BagError(name_ + ": MCAP record at offset " + std::to_string(pos) + " is cut short (torn file?)");
    const std::uint8_t opcode = bytes_[pos];
    std::uint64_t length;
    std::memcpy(&length, bytes_.data() + pos + 1, 8);
    if (length > bytes_.size() - pos - 9)
      throw BagError(name_ + ": MCAP record at offset " + std::to_string(pos) + " claims " +
                     std::to_string(length) + " bytes, past the end of the file (torn file?)");
    const auto body = bytes_.subspan(pos + 9, length);
    if (opcode == kChunk) {
      Fields f(body, pos + 9, name_, "Chunk");
      f.get<std::uint64_t>("message_start_time");
      f.get<std::uint64_t>("message_end_time");
      Chunk c;
      c.uncompressed_size = f.get<std::uint64_t>("uncompressed_size");
      c.uncompressed_crc = f.get<std::uint32_t>("uncompressed_crc");
      c.compression = f.string("compression");
      c.records_size = f.get<std::uint64_t>("records length");
      c.records_offset = f.at();
      f.bytes(c.records_size, "records");
      if (c.compression != "" && c.compression != "zstd" && c.compression != "lz4")
        throw BagError(name_ + ": MCAP chunk at offset " + std::to_string(pos) + " uses compression '" +
                       c.compression + "' (densemap reads none, zstd and lz4)");
      if (c.uncompressed_size > kMaxChunkBytes || c.uncompressed_size > kMaxRatio * c.records_size + 4096)
        throw BagError(name_ + ": MCAP chunk at offset " + std::to_string(pos) + " claims " +
                       std::to_string(c.uncompressed_size) + " uncompressed bytes from " +
                       std::to_string(c.records_size) + " (refused: corrupt or hostile)");
      if (c.compression.empty() && c.uncompressed_size != c.records_size)
        throw BagError(name_ + ": uncompressed MCAP chunk at offset " + std::to_string(pos) + " claims " +
                       std::to_string(c.uncompressed_size) + " bytes but holds " +
                       std::to_string(c.records_size));
      chunks_.push_back(c);
      const std::vector<std::uint8_t> records = chunkRecords(chunks_.size() - 1);
      indexRecords(records, c.records_offset, static_cast<std::int64_t>(chunks_.size() - 1));
    } else if (opcode == kDataEnd || opcode == kFooter) {
      ended = true;  // the summary section repeats what the data section held
    } else {
      indexRecords(bytes_.subspan(pos, 9 + length), pos, -1);
    }
    pos += 9 + length;
  }
  if (!ended || std::memcmp(bytes_.data() + bytes_.size() - sizeof kMagic, kMagic, sizeof kMagic) != 0)
    throw BagError(name_ + ": MCAP file ends at offset " + std::to_string(bytes_.size()) +
                   " without its data end, footer and closing magic (a recording cut short? `mcap recover` "
                   "rewrites such a file)");
  std::stable_sort(messages_.begin(), messages_.end(), [](const BagMessageRef& a, const BagMessageRef& b) {
    return a.log_time_ns < b.log_time_ns;
  });
}

std::vector<std::uint8_t> McapReader::chunkRecords(std::size_t index) const {
  const Chunk& c = chunks_[index];
  const auto in = bytes_.subspan(c.records_offset, c.records_size);
  std::vector<std::uint8_t> out;
  const std::string where = name_ + ": MCAP chunk records at offset " + std::to_string(c.records_offset);
  if (c.compression.empty()) {
    out.assign(in.begin(), in.end());
  } else if (c.compression == "zstd") {
    out.resize(c.uncompressed_size);
    const std::size_t n = ZSTD_decompress(out.data(), out.size(), in.data(), in.size());
    if (ZSTD_isError(n)) throw BagError(where + ": zstd: " + ZSTD_getErrorName(n));
    if (n != c.uncompressed_size)
      throw BagError(where + ": zstd gave " + std::to_string(n) + " bytes, the chunk claims " +
                     std::to_string(c.uncompressed_size));
  } else {
    out.resize(c.uncompressed_size);
    LZ4F_dctx* ctx = nullptr;
    if (LZ4F_isError(LZ4F_createDecompressionContext(&ctx, LZ4F_VERSION)))
      throw BagError(where + ": lz4 context");
    std::unique_ptr<LZ4F_dctx, decltype(&LZ4F_freeDecompressionContext)> guard(ctx,
                                                                               LZ4F_freeDecompressionContext);
    std::size_t produced = 0, consumed = 0;
    while (true) {
      std::size_t dst = out.size() - produced, src = in.size() - consumed;
      const std::size_t hint =
          LZ4F_decompress(ctx, out.data() + produced, &dst, in.data() + consumed, &src, nullptr);
      if (LZ4F_isError(hint)) throw BagError(where + ": lz4: " + LZ4F_getErrorName(hint));
      produced += dst;
      consumed += src;
      if (hint == 0) break;  // frame complete
      if ((src == 0 && dst == 0) || consumed == in.size())
        throw BagError(where + ": lz4 frame is cut short or larger than the chunk claims");
    }
    if (produced != c.uncompressed_size)
      throw BagError(where + ": lz4 gave " + std::to_string(produced) + " bytes, the chunk claims " +
                     std::to_string(c.uncompressed_size));
  }
  if (c.uncompressed_crc != 0) {
    const auto crc = static_cast<std::uint32_t>(::crc32(0L, out.data(), static_cast<uInt>(out.size())));
    if (crc != c.uncompressed_crc)
      throw BagError(where + ": CRC mismatch (corrupt chunk: recorded " + std::to_string(c.uncompressed_crc) +
                     ", computed " + std::to_string(crc) + ")");
  }
  return out;
}

void McapReader::indexRecords(std::span<const std::uint8_t> records, std::uint64_t base, std::int64_t chunk) {
  std::uint64_t pos = 0;
  while (pos < records.size()) {
    const std::uint64_t at = base + pos;
    if (records.size() - pos < 9)
      throw BagError(name_ + ": MCAP record at offset " + std::to_string(at) + " is cut short");
    const std::uint8_t opcode = records[pos];
    std::uint64_t length;
    std::memcpy(&length, records.data() + pos + 1, 8);
    if (length > records.size() - pos - 9)
      throw BagError(name_ + ": MCAP record at offset " + std::to_string(at) + " claims " +
                     std::to_string(length) + " bytes, more than its " + (chunk < 0 ? "file" : "chunk") +
                     " holds");
    if (opcode == kHeader) {
      Fields h(records.subspan(pos + 9, length), at + 9, name_, "Header");
      const std::string profile = h.string("profile");
      if (!profile.empty() && profile != "ros2")
        throw BagError(name_ + ": MCAP profile '" + profile +
                       "' is not ros2 (densemap reads ROS 2 recordings)");
    } else if (opcode == kSchema) {
      Fields s(records.subspan(pos + 9, length), at + 9, name_, "Schema");
      const auto id = s.get<std::uint16_t>("id");
      std::string name = s.string("name");
      std::string encoding = s.string("encoding");
      schemas_[id] = {std::move(name), std::move(encoding)};
    } else if (opcode == kChannel) {
      Fields c(records.subspan(pos + 9, length), at + 9, name_, "Channel");
      const auto id = c.get<std::uint16_t>("id");
      const auto schema = c.get<std::uint16_t>("schema_id");
      BagTopic topic;
      topic.name = c.string("topic");
      topic.serialization_format = c.string("message_encoding");
      const auto map_bytes = c.get<std::uint32_t>("metadata length");
      Fields m(c.bytes(map_bytes, "metadata"), c.at() - map_bytes, name_, "Channel metadata");
      for (std::uint32_t used = 0; used < map_bytes;) {
        const std::uint64_t before = m.at();
        const std::string key = m.string("key");
        std::string value = m.string("value");
        used += static_cast<std::uint32_t>(m.at() - before);
        if (key == "offered_qos_profiles") topic.offered_qos_profiles = std::move(value);
      }
      auto s = schemas_.find(schema);
      if (schema != 0 && s == schemas_.end())
        throw BagError(name_ + ": MCAP channel " + std::to_string(id) + " at offset " + std::to_string(at) +
                       " names schema " + std::to_string(schema) + ", which comes nowhere before it");
      if (s != schemas_.end()) topic.type = s->second.first;
      if (!channel_topic_.count(id)) {
        channel_topic_[id] = topics_.size();
        topics_.push_back(std::move(topic));
      }
    } else if (opcode == kMessage) {
      Fields msg(records.subspan(pos + 9, length), at + 9, name_, "Message");
      const auto channel = msg.get<std::uint16_t>("channel_id");
      msg.get<std::uint32_t>("sequence");
      const auto log_time = msg.get<std::uint64_t>("log_time");
      auto it = channel_topic_.find(channel);
      if (it == channel_topic_.end())
        throw BagError(name_ + ": MCAP message at offset " + std::to_string(at) + " is on channel " +
                       std::to_string(channel) + ", which comes nowhere before it");
      if (log_time > static_cast<std::uint64_t>(INT64_MAX))
        throw BagError(name_ + ": MCAP message at offset " + std::to_string(at) +
                       " has a log time past 2262");
      const std::uint64_t locator =
          chunk < 0 ? at : (static_cast<std::uint64_t>(chunk + 1) << kChunkShift) | pos;
      messages_.push_back({it->second, static_cast<std::int64_t>(log_time), locator});
    }
    pos += 9 + length;
  }
}

std::vector<std::uint8_t> McapReader::readMessage(const BagMessageRef& message) const {
  const std::uint64_t chunk = message.locator >> kChunkShift;
  const std::uint64_t offset = message.locator & ((1ull << kChunkShift) - 1);
  auto extract = [&](std::span<const std::uint8_t> records) {
    std::uint64_t length;
    std::memcpy(&length, records.data() + offset + 1, 8);
    const std::size_t header = 9 + 2 + 4 + 8 + 8;
    const auto data = records.subspan(offset + header, length - (header - 9));
    return std::vector<std::uint8_t>(data.begin(), data.end());
  };
  if (chunk == 0) return extract(bytes_);
  std::lock_guard lock(cache_mutex_);
  if (cached_chunk_ != static_cast<std::int64_t>(chunk - 1)) {
    cached_records_ = chunkRecords(chunk - 1);
    cached_chunk_ = static_cast<std::int64_t>(chunk - 1);
  }
  return extract(cached_records_);
}

std::string McapReader::describe() const {
  return "MCAP " + name_ + " (" + std::to_string(messages_.size()) + " messages on " +
         std::to_string(topics_.size()) + " topics, " + std::to_string(chunks_.size()) + " chunks)";
}

}  // namespace densemap::ros2
