#include "densemap/server/dds_edge/reply_writers.h"

#include <pthread.h>

#include <algorithm>
#include <vector>

#include <spdlog/spdlog.h>

#include "densemap/msg/peer_topic.h"
#include "densemap/util/realtime_priority.h"

namespace densemap::server::dds_edge {

namespace fdds = eprosima::fastdds::dds;
using namespace std::chrono_literals;

namespace {
// A writer whose client has no reader left is removed after this long unused (a client that restarts with
// the same id within it finds its writer still there).
constexpr auto kIdleWriterRemoval = 30s;
}  // namespace

ReplyWriters::ReplyWriters(msg::DdsNode& node, std::string reply_topic,
                           std::function<fdds::TypeSupport()> type, WriterQos qos, std::size_t max_clients,
                           std::function<void(const std::string&, fdds::DataWriter&)> on_made)
    : node_(node),
      base_(std::move(reply_topic)),
      wire_base_(node.topicName(base_)),
      type_(std::move(type)),
      qos_(std::move(qos)),
      on_made_(std::move(on_made)),
      max_clients_(max_clients) {
  thread_ = std::thread([this] {
    pthread_setname_np(pthread_self(), "dm-reply-topics");
    util::useBulkScheduling();  // not real-time: it only makes and removes writers
    maintain();
  });
}

ReplyWriters::~ReplyWriters() { stop(); }

std::shared_ptr<ReplyWriters::Entry> ReplyWriters::find(const std::string& client_id) {
  auto it = writers_.find(client_id);
  if (it == writers_.end()) return nullptr;
  it->second->last_used = std::chrono::steady_clock::now();
  return it->second;
}

bool ReplyWriters::accepts(const std::string& client_id) const {
  return running_ && msg::checkPeerId(client_id).empty() && writers_.size() < max_clients_;
}

std::shared_ptr<ReplyWriters::Entry> ReplyWriters::get(const std::string& client_id) {
  {
    std::lock_guard lock(mutex_);
    if (auto e = find(client_id)) return e;
  }
  // One writer made at a time (two threads replying to one new client make one), and never under mutex_:
  // DDS calls readerDiscovered() with its own locks held while making a writer may wait for them.
  std::lock_guard making(make_mutex_);
  {
    std::lock_guard lock(mutex_);
    if (auto e = find(client_id)) return e;
    if (!accepts(client_id)) {
      ++refused_;
      return nullptr;
    }
  }
  auto e = std::make_shared<Entry>();
  auto* topic = node_.topic(msg::peerTopicOf(base_, client_id), type_());
  e->writer = std::visit([&](const auto& qos) { return node_.writer(topic, qos); }, qos_);
  e->last_used = std::chrono::steady_clock::now();
  if (on_made_) on_made_(client_id, *e->writer);  // before the writer is shared: its first sample
  std::lock_guard lock(mutex_);
  writers_[client_id] = e;
  return e;
}

bool ReplyWriters::write(const std::string& client_id, void* sample) {
  std::shared_ptr<Entry> e = get(client_id);
  if (!e) return false;
  return e->writer->write(sample);
}

ReplyWriters::Written ReplyWriters::writeIfMade(const std::string& client_id, void* sample) {
  std::shared_ptr<Entry> e;
  {
    std::lock_guard lock(mutex_);
    e = find(client_id);
    if (!e) {
      if (accepts(client_id)) return Written::kNoWriterYet;
      ++refused_;
      return Written::kRefused;
    }
  }
  return e->writer->write(sample) ? Written::kYes : Written::kRefused;
}

bool ReplyWriters::has(const std::string& client_id) const {
  std::lock_guard lock(mutex_);
  return writers_.count(client_id) != 0;
}

void ReplyWriters::readerDiscovered(const std::string& wire_topic) {
  auto id = msg::peerOfTopic(wire_base_, wire_topic);
  if (!id) return;
  {
    std::lock_guard lock(pending_mutex_);
    if (discovered_.size() >= max_clients_) return;  // bounded: the rest are made at their first request
    discovered_.insert(*id);
  }
  wake_.notify_one();
}

void ReplyWriters::maintain() {
  for (;;) {
    std::set<std::string> todo;
    {
      std::unique_lock lock(pending_mutex_);
      wake_.wait_for(lock, 1s, [&] { return !discovered_.empty() || stopping_; });
      if (stopping_) return;
      todo.swap(discovered_);
    }
    for (const std::string& id : todo) {
      try {
        get(id);  // DDS entities are made here, never on DDS's discovery thread
      } catch (const msg::DdsError& e) {
        spdlog::warn("reply topic for client '{}': {}", id, e.what());
      }
    }
    // Writers no client reads any more, unused for a while, and held by no write in progress (use_count 1).
    std::vector<fdds::DataWriter*> gone;
    {
      std::lock_guard lock(mutex_);
      const auto now = std::chrono::steady_clock::now();
      for (auto it = writers_.begin(); it != writers_.end();) {
        fdds::PublicationMatchedStatus st;
        it->second->writer->get_publication_matched_status(st);
        if (st.current_count == 0 && now - it->second->last_used > kIdleWriterRemoval &&
            it->second.use_count() == 1) {
          gone.push_back(it->second->writer);
          it = writers_.erase(it);
        } else {
          ++it;
        }
      }
    }
    for (auto* w : gone) node_.remove(w);
  }
}

void ReplyWriters::stop() {
  {
    std::lock_guard lock(pending_mutex_);
    stopping_ = true;
  }
  {
    std::lock_guard making(make_mutex_);
    std::lock_guard lock(mutex_);
    running_ = false;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
  std::map<std::string, std::shared_ptr<Entry>> all;
  {
    std::lock_guard lock(mutex_);
    all.swap(writers_);
  }
  for (auto& [id, e] : all) {
    // A write still in progress holds its entry: wait for it (bounded) before the writer goes.
    for (int i = 0; i < 2000 && e.use_count() > 1; ++i) std::this_thread::sleep_for(1ms);
    node_.remove(e->writer);
  }
}

bool ReplyWriters::waitForAcknowledgments(double timeout_s) {
  std::vector<std::shared_ptr<Entry>> all;
  {
    std::lock_guard lock(mutex_);
    for (auto& [id, e] : writers_) all.push_back(e);
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  bool ok = true;
  for (auto& e : all) {
    const double left = std::chrono::duration<double>(deadline - std::chrono::steady_clock::now()).count();
    ok &= e->writer->wait_for_acknowledgments(eprosima::fastrtps::Duration_t(
              static_cast<long double>(std::max(0.0, left)))) == ReturnCode_t::RETCODE_OK;
  }
  return ok;
}

std::size_t ReplyWriters::size() const {
  std::lock_guard lock(mutex_);
  return writers_.size();
}

std::uint64_t ReplyWriters::refused() const {
  std::lock_guard lock(mutex_);
  return refused_;
}

}  // namespace densemap::server::dds_edge
