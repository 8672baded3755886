#include "densemap/server/dds_edge/scan_readers.h"

#include <spdlog/spdlog.h>
#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>

#include "densemap/msg/peer_topic.h"
#include "densemap/msg/wire_types.h"

namespace densemap::server::dds_edge {

namespace fdds = eprosima::fastdds::dds;
using namespace std::chrono_literals;

namespace {
// A reader whose robot has had no writer this long, and which holds nothing, is removed (a robot that
// restarts within it finds its reader still there).
constexpr auto kIdleReaderRemoval = 30s;
}  // namespace

class ScanReaders::Listener : public fdds::DataReaderListener {
 public:
  explicit Listener(ScanReaders& r) : r_(r) {}
  void on_data_available(fdds::DataReader*) override { r_.wake_(); }

 private:
  ScanReaders& r_;
};

ScanReaders::ScanReaders(msg::DdsNode& node, std::size_t max_robots, std::function<void()> wake)
    : node_(node),
      wire_base_(node.topicName(msg::kScanTopic)),
      max_robots_(max_robots),
      wake_(std::move(wake)),
      listener_(std::make_unique<Listener>(*this)),
      next_(readers_.end()),
      last_idle_check_(std::chrono::steady_clock::now()) {}

ScanReaders::~ScanReaders() { removeAll(); }

void ScanReaders::writerDiscovered(const std::string& wire_topic) {
  auto id = msg::peerOfTopic(wire_base_, wire_topic);
  if (!id) return;
  {
    std::lock_guard lock(pending_mutex_);
    if (discovered_.size() >= max_robots_) return;  // bounded; the rest are counted when adopted
    discovered_.insert(std::move(*id));
  }
  wake_();
}

void ScanReaders::adoptDiscovered() {
  std::set<std::string> todo;
  {
    std::lock_guard lock(pending_mutex_);
    todo.swap(discovered_);
  }
  for (const std::string& id : todo) {
    if (readers_.count(id)) continue;
    if (readers_.size() >= max_robots_) {
      ++refused_;
      spdlog::warn("scans of robot '{}' not read: {} robots have a scan reader already (--max-robots)", id,
                   max_robots_);
      continue;
    }
    try {
      auto* topic =
          node_.topic(msg::peerTopicOf(msg::kScanTopic, id), msg::typeSupport<msg::ScanPubSubType>());
      Entry e;
      e.reader = node_.reader(topic, msg::kScanReaderProfile, listener_.get());
      e.unmatched_since = std::chrono::steady_clock::now();
      readers_.emplace(id, e);
      spdlog::debug("scan reader for robot '{}'", id);
    } catch (const msg::DdsError& e) {
      spdlog::warn("scan topic of robot '{}': {}", id, e.what());
    }
  }
  next_ = readers_.end();  // the map changed: start the round again
}

void ScanReaders::removeIdle() {
  const auto now = std::chrono::steady_clock::now();
  if (now - last_idle_check_ < 1s) return;
  last_idle_check_ = now;
  for (auto it = readers_.begin(); it != readers_.end();) {
    fdds::SubscriptionMatchedStatus st;
    it->second.reader->get_subscription_matched_status(st);
    if (st.current_count > 0) it->second.unmatched_since = now;
    // With no writer left nothing new arrives, so nothing unread is lost with the reader.
    if (st.current_count == 0 && now - it->second.unmatched_since > kIdleReaderRemoval &&
        it->second.reader->get_unread_count() == 0) {
      node_.remove(it->second.reader);
      it = readers_.erase(it);
      next_ = readers_.end();
    } else {
      ++it;
    }
  }
}

bool ScanReaders::take(msg::Scan& scan, std::string& robot) {
  bool pending = false;
  {
    std::lock_guard lock(pending_mutex_);
    pending = !discovered_.empty();
  }
  if (pending) adoptDiscovered();
  removeIdle();
  fdds::SampleInfo info;
  // One scan per robot in turn, starting after the robot that gave the last one.
  for (std::size_t tried = 0; tried < readers_.size(); ++tried) {
    if (next_ == readers_.end()) next_ = readers_.begin();
    auto it = next_++;
    while (it->second.reader->take_next_sample(&scan, &info) == ReturnCode_t::RETCODE_OK) {
      if (!info.valid_data) continue;
      robot = it->first;
      return true;
    }
  }
  return false;
}

std::size_t ScanReaders::size() const { return readers_.size(); }

void ScanReaders::removeAll() {
  for (auto& [id, e] : readers_) node_.remove(e.reader);
  readers_.clear();
  next_ = readers_.end();
}

}  // namespace densemap::server::dds_edge
