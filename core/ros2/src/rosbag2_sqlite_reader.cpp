#include "densemap/ros2/rosbag2_sqlite_reader.h"

#include <sqlite3.h>

#include <algorithm>
#include <map>
#include <mutex>

namespace densemap::ros2 {

namespace {
constexpr int kFileShift = 48;  // locator = file << 48 | message row id
}

struct Rosbag2SqliteReader::Database {
  std::string path;
  sqlite3* db = nullptr;
  sqlite3_stmt* read = nullptr;
  std::mutex mutex;  // one prepared statement, shared by readers
  ~Database() {
    sqlite3_finalize(read);
    sqlite3_close(db);
  }
  [[noreturn]] void fail(const std::string& what) const {
    throw BagError(path + ": " + what + " (" + (db ? sqlite3_errmsg(db) : "cannot open") +
                   "); is this a rosbag2 sqlite3 file?");
  }
};

Rosbag2SqliteReader::Rosbag2SqliteReader(std::vector<std::string> files) {
  std::map<std::string, std::size_t> topic_by_name;
  for (std::size_t file = 0; file < files.size(); ++file) {
    auto d = std::make_unique<Database>();
    d->path = files[file];
    // immutable=1: no locks, no journal, nothing written, so a bag on read-only media opens.
    const std::string uri = "file:" + d->path + "?immutable=1";
    if (sqlite3_open_v2(uri.c_str(), &d->db, SQLITE_OPEN_READONLY | SQLITE_OPEN_URI, nullptr) != SQLITE_OK)
      d->fail("cannot open");
    std::map<std::int64_t, std::size_t> topic_of_id;
    sqlite3_stmt* st = nullptr;
    if (sqlite3_prepare_v2(d->db, "SELECT * FROM topics", -1, &st, nullptr) != SQLITE_OK)
      d->fail("no topics table");
    std::map<std::string, int> column;
    for (int c = 0; c < sqlite3_column_count(st); ++c) column[sqlite3_column_name(st, c)] = c;
    for (const char* needed : {"id", "name", "type", "serialization_format"})
      if (!column.count(needed)) {
        sqlite3_finalize(st);
        d->fail(std::string("topics table has no column '") + needed + "'");
      }
    auto text = [&](const char* name) {
      auto it = column.find(name);
      if (it == column.end()) return std::string();
      const auto* t = sqlite3_column_text(st, it->second);
      return t ? std::string(reinterpret_cast<const char*>(t)) : std::string();
    };
    int rc;
    while ((rc = sqlite3_step(st)) == SQLITE_ROW) {
      BagTopic t{text("name"), text("type"), text("serialization_format"), text("offered_qos_profiles")};
      auto [it, inserted] = topic_by_name.emplace(t.name, topics_.size());
      if (inserted) topics_.push_back(std::move(t));
      topic_of_id[sqlite3_column_int64(st, column["id"])] = it->second;
    }
    sqlite3_finalize(st);
    if (rc != SQLITE_DONE) d->fail("reading the topics table failed");

    if (sqlite3_prepare_v2(d->db, "SELECT id, topic_id, timestamp FROM messages ORDER BY timestamp, id", -1,
                           &st, nullptr) != SQLITE_OK)
      d->fail("no messages table");
    while ((rc = sqlite3_step(st)) == SQLITE_ROW) {
      const std::int64_t id = sqlite3_column_int64(st, 0);
      auto topic = topic_of_id.find(sqlite3_column_int64(st, 1));
      if (topic == topic_of_id.end() || id < 0 || id >= (std::int64_t{1} << kFileShift)) {
        sqlite3_finalize(st);
        d->fail("message " + std::to_string(id) + " names a topic the topics table does not hold");
      }
      messages_.push_back(
          {topic->second, sqlite3_column_int64(st, 2),
           (static_cast<std::uint64_t>(file) << kFileShift) | static_cast<std::uint64_t>(id)});
    }
    sqlite3_finalize(st);
    if (rc != SQLITE_DONE) d->fail("reading the messages table failed (corrupt file?)");
    if (sqlite3_prepare_v2(d->db, "SELECT data FROM messages WHERE id = ?", -1, &d->read, nullptr) !=
        SQLITE_OK)
      d->fail("cannot prepare the message query");
    databases_.push_back(std::move(d));
  }
  std::stable_sort(messages_.begin(), messages_.end(), [](const BagMessageRef& a, const BagMessageRef& b) {
    return a.log_time_ns < b.log_time_ns;
  });
}

Rosbag2SqliteReader::~Rosbag2SqliteReader() = default;

std::vector<std::uint8_t> Rosbag2SqliteReader::readMessage(const BagMessageRef& message) const {
  const std::size_t file = message.locator >> kFileShift;
  const auto id = static_cast<std::int64_t>(message.locator & ((1ull << kFileShift) - 1));
  Database& d = *databases_.at(file);
  std::lock_guard lock(d.mutex);
  sqlite3_reset(d.read);
  sqlite3_bind_int64(d.read, 1, id);
  if (sqlite3_step(d.read) != SQLITE_ROW) d.fail("message " + std::to_string(id) + " cannot be read");
  const auto* blob = static_cast<const std::uint8_t*>(sqlite3_column_blob(d.read, 0));
  const int n = sqlite3_column_bytes(d.read, 0);
  std::vector<std::uint8_t> out(blob, blob + std::max(n, 0));
  sqlite3_reset(d.read);
  return out;
}

std::string Rosbag2SqliteReader::describe() const {
  return "rosbag2 sqlite3 " + (databases_.empty() ? std::string("(no files)") : databases_.front()->path) +
         " (" + std::to_string(messages_.size()) + " messages on " + std::to_string(topics_.size()) +
         " topics)";
}

}  // namespace densemap::ros2
