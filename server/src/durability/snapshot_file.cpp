#include "densemap/server/durability/snapshot_file.h"

#include <cmath>

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include <fmt/format.h>

#include "densemap/server/durability/checksum.h"
#include "densemap/server/durability/journal_segment.h"
#include "densemap/util/byte_codec.h"

namespace densemap::server::durability {

namespace {
constexpr std::uint64_t kMagic = 0x31305041534D4D44ull;     // "DMMSAP01"
constexpr std::uint64_t kEndMagic = 0x444E4550414E5344ull;  // "DSNAPEND"
constexpr std::uint32_t kVersion = 1;
constexpr std::size_t kFooterBytes = 8 + 4 + 8;
enum Tag : std::uint32_t { kProgress = 1, kMap = 2, kDense = 3, kMapTime = 4, kWindow = 5 };

const char* tagName(std::uint32_t t) {
  switch (t) {
    case kProgress:
      return "robot progress";
    case kMap:
      return "map";
    case kDense:
      return "dense layer";
    case kMapTime:
      return "map time";
    case kWindow:
      return "map window";
  }
  return "unknown";
}
}  // namespace

std::string encodeSnapshot(const SnapshotContents& s) {
  std::string out;
  out.reserve(s.map.size() + s.dense.size() + s.progress.size() + 256);
  util::ByteWriter w(out);
  w.put(kMagic);
  w.put(kVersion);
  w.put(s.lsn);
  w.put(s.created_ns);
  w.string(s.fingerprint);
  // The map time (decay's clock) is optional and last, so snapshots without decay read as before.
  std::string map_time;
  if (s.map_time_s) util::ByteWriter(map_time).put(*s.map_time_s);
  for (auto [tag, bytes] : {std::pair<std::uint32_t, const std::string*>{kProgress, &s.progress},
                            {kMap, &s.map},
                            {kDense, &s.dense},
                            {kMapTime, &map_time},
                            {kWindow, &s.window}}) {
    if ((tag == kMapTime || tag == kWindow) && bytes->empty()) continue;
    w.put(tag);
    w.put(static_cast<std::uint64_t>(bytes->size()));
    w.put(crc32Of(*bytes));
    w.bytes(bytes->data(), bytes->size());
  }
  const std::uint64_t length = out.size();
  const std::uint32_t crc = crc32Of(out);
  w.put(length);
  w.put(crc);
  w.put(kEndMagic);
  return out;
}

SnapshotContents decodeSnapshot(std::string_view bytes) {
  if (bytes.size() < kFooterBytes + 12)
    throw util::FormatError("a snapshot cut short (" + std::to_string(bytes.size()) + " bytes)", 0);
  std::uint32_t footer_crc = 0;
  {
    util::ByteReader footer(bytes.substr(bytes.size() - kFooterBytes), bytes.size() - kFooterBytes);
    const auto length = footer.get<std::uint64_t>("footer length");
    const auto crc = footer.get<std::uint32_t>("footer crc");
    if (footer.get<std::uint64_t>("end magic") != kEndMagic || length != bytes.size() - kFooterBytes)
      throw util::FormatError("the snapshot's end is missing (a truncated file)", bytes.size());
    footer_crc = crc;
  }
  util::ByteReader r(bytes.substr(0, bytes.size() - kFooterBytes));
  SnapshotContents s;
  if (r.get<std::uint64_t>("snapshot magic") != kMagic) r.fail("not a densemap snapshot");
  if (const auto v = r.get<std::uint32_t>("snapshot version"); v != kVersion)
    r.fail(fmt::format("snapshot version {} (this server reads {})", v, kVersion));
  s.lsn = r.get<std::uint64_t>("lsn");
  s.created_ns = r.get<std::int64_t>("created");
  s.fingerprint = r.string("fingerprint", 1 << 16);
  // Three sections always, then the optional ones, each at most once and in this order.
  for (std::uint32_t want : {kProgress, kMap, kDense, kMapTime, kWindow}) {
    if (want >= kMapTime && r.done()) break;
    const std::size_t at = r.offset();
    const auto tag = r.get<std::uint32_t>("section tag");
    if (want == kMapTime && tag == kWindow) {
      want = kWindow;  // no map time (decay off)
    } else if (want == kWindow && tag != kWindow) {
      r.fail(fmt::format("section {} after the optional ones", tag));
    }
    if (tag != want)
      throw util::FormatError(fmt::format("section {} where the {} was due", tag, tagName(want)), at);
    const std::uint64_t n = r.count("section length", 1);
    const auto crc = r.get<std::uint32_t>("section crc");
    const std::size_t body = r.offset();
    std::string_view data(r.take(n, tagName(tag)), n);
    if (crc32Of(data) != crc)
      throw util::FormatError(fmt::format("the {} section fails its checksum", tagName(tag)), body);
    if (tag == kMapTime) {
      util::ByteReader t(data, body);
      const auto v = t.get<double>("map time");
      if (!t.done() || !std::isfinite(v))
        throw util::FormatError("the map time is not one finite number", body);
      s.map_time_s = v;
      continue;
    }
    if (tag == kWindow) {
      if (data.empty()) throw util::FormatError("an empty map window section", body);
      s.window.assign(data);
      break;  // the last one
    }
    (tag == kProgress ? s.progress : tag == kMap ? s.map : s.dense).assign(data);
  }
  if (!r.done()) r.fail("bytes after the snapshot's sections");
  // Last: the sections' own checksums said where a damaged part is; this covers the header too.
  if (footer_crc != crc32Of(bytes.substr(0, bytes.size() - kFooterBytes)))
    throw util::FormatError("the snapshot's header fails the file's checksum", 0);
  return s;
}

std::string snapshotFileName(std::uint64_t lsn) { return fmt::format("{:020}.dms", lsn); }

std::optional<std::uint64_t> snapshotLsn(const std::string& name) { return lsnOfFileName(name, ".dms"); }

void writeFileAtomically(const std::filesystem::path& path, std::string_view bytes) {
  const std::filesystem::path tmp = path.string() + ".tmp";
  std::error_code ec;
  auto fail = [&](const std::string& what) {
    const std::string err = std::strerror(errno);
    std::filesystem::remove(tmp, ec);
    throw StorageError(fmt::format("cannot write {}: {} ({})", path.string(), what, err));
  };
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) fail("create " + tmp.string());
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t w = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) {
      if (w == 0) errno = EIO;
      ::close(fd);
      fail(fmt::format("write at offset {}", done));
    }
    done += static_cast<std::size_t>(w);
  }
  if (::fsync(fd) != 0) {
    ::close(fd);
    fail("fsync");
  }
  ::close(fd);
  if (::rename(tmp.c_str(), path.c_str()) != 0) fail("rename");
  syncDirectory(path.parent_path());
}

}  // namespace densemap::server::durability
