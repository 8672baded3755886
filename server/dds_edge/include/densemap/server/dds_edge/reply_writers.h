// The server's side of the per-client reply topics (msg/peer_topic.h): one writer per client, made when
// the client's reply reader is discovered (so the client sees its reply topic matched before it asks) or
// at its first request, and removed when its readers are gone. Bounded: a flood of client ids cannot make
// unbounded writers.
#pragma once

#include <chrono>
#include <condition_variable>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <variant>

#include "densemap/msg/dds_node.h"

namespace densemap::server::dds_edge {

class ReplyWriters {
 public:
  /// `reply_topic`: the base name (msg::kQueryReplyTopic); `type`: makes its type support; `qos`: a
  /// profile name or explicit QoS; `on_made`: called with each new writer and its peer id before any
  /// other write can reach it, e.g. to write the transient-local sample the peer reads first.
  using WriterQos = std::variant<std::string, eprosima::fastdds::dds::DataWriterQos>;
  ReplyWriters(msg::DdsNode& node, std::string reply_topic,
               std::function<eprosima::fastdds::dds::TypeSupport()> type, WriterQos qos,
               std::size_t max_clients,
               std::function<void(const std::string&, eprosima::fastdds::dds::DataWriter&)> on_made = {});
  ~ReplyWriters();
  ReplyWriters(const ReplyWriters&) = delete;
  ReplyWriters& operator=(const ReplyWriters&) = delete;

  /// Writes `sample` to `client_id`'s reply topic; false (and nothing written) when the id is not a valid
  /// client id or max_clients writers exist already.
  bool write(const std::string& client_id, void* sample);

  enum class Written { kYes, kRefused, kNoWriterYet };
  /// Like write(), but never makes a writer, so never waits for one being made: for DDS's listener threads,
  /// which hold a reader's lock that making a writer may need in turn (a deadlock otherwise).
  Written writeIfMade(const std::string& client_id, void* sample);
  /// Whether `client_id`'s writer exists now.
  bool has(const std::string& client_id) const;

  /// A reader on some topic was discovered (DDS's discovery thread): makes the writer soon when the topic
  /// is one of our reply topics. Never blocks on DDS.
  void readerDiscovered(const std::string& wire_topic);

  /// Waits up to `timeout_s` until every writer's samples are acknowledged by its readers; false if not.
  bool waitForAcknowledgments(double timeout_s);

  std::size_t size() const;
  /// Writes refused because of max_clients or an invalid id.
  std::uint64_t refused() const;

  /// Removes every writer and stops the maintenance thread (before the node closes).
  void stop();

 private:
  struct Entry {
    eprosima::fastdds::dds::DataWriter* writer = nullptr;
    std::chrono::steady_clock::time_point last_used;
  };
  std::shared_ptr<Entry> get(const std::string& client_id);
  std::shared_ptr<Entry> find(const std::string& client_id);  // under mutex_
  /// Whether a new writer may be made for `client_id` (a valid id, below max_clients); under mutex_.
  bool accepts(const std::string& client_id) const;
  void maintain();

  msg::DdsNode& node_;
  const std::string base_, wire_base_;
  std::function<eprosima::fastdds::dds::TypeSupport()> type_;
  const WriterQos qos_;
  const std::function<void(const std::string&, eprosima::fastdds::dds::DataWriter&)> on_made_;
  const std::size_t max_clients_;
  mutable std::mutex mutex_;
  std::mutex make_mutex_;     // held while a writer is made (not mutex_: see get())
  std::mutex pending_mutex_;  // the only lock readerDiscovered() takes
  std::condition_variable wake_;
  std::map<std::string, std::shared_ptr<Entry>> writers_;  // guarded by mutex_
  std::uint64_t refused_ = 0;                              // guarded by mutex_
  bool running_ = true;                                    // guarded by mutex_
  std::set<std::string> discovered_;                       // to make; guarded by pending_mutex_
  bool stopping_ = false;                                  // guarded by pending_mutex_
  std::thread thread_;
};

}  // namespace densemap::server::dds_edge
