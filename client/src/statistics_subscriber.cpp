#include "densemap/client/statistics_subscriber.h"

#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>

#include "densemap/msg/wire_types.h"

namespace densemap::client {

namespace dds = eprosima::fastdds::dds;

class StatisticsSubscriber::Listener : public dds::DataReaderListener {
 public:
  explicit Listener(StatisticsSubscriber& s) : s_(s) {}
  void on_data_available(dds::DataReader* r) override { s_.onData(r); }

 private:
  StatisticsSubscriber& s_;
};

StatisticsSubscriber::StatisticsSubscriber(msg::DdsNode& node) : node_(node) {
  listener_ = std::make_unique<Listener>(*this);
  auto* topic = node_.topic(msg::kStatisticsTopic, msg::typeSupport<msg::ServerStatisticsPubSubType>());
  reader_ = node_.reader(topic, msg::kMessageReaderProfile, listener_.get());
}

StatisticsSubscriber::~StatisticsSubscriber() { node_.remove(reader_); }

void StatisticsSubscriber::onData(dds::DataReader* reader) {
  msg::ServerStatistics s;
  dds::SampleInfo info;
  std::lock_guard lock(mutex_);
  while (reader->take_next_sample(&s, &info) == ReturnCode_t::RETCODE_OK) {
    if (info.valid_data) last_ = s;
  }
  changed_.notify_all();
}

std::optional<msg::ServerStatistics> StatisticsSubscriber::waitForNext(std::chrono::milliseconds timeout) {
  const std::int64_t since = msg::nowNs();
  auto s = waitUntil([](const msg::ServerStatistics&) { return true; }, timeout);
  return s && s->stamp_ns() >= since ? s : std::nullopt;
}

std::optional<msg::ServerStatistics> StatisticsSubscriber::waitUntil(
    const std::function<bool(const msg::ServerStatistics&)>& done, std::chrono::milliseconds timeout) {
  const std::int64_t since = msg::nowNs();
  std::unique_lock lock(mutex_);
  changed_.wait_for(lock, timeout, [&] { return last_ && last_->stamp_ns() >= since && done(*last_); });
  return last_;
}

std::optional<msg::ServerStatistics> StatisticsSubscriber::last() const {
  std::lock_guard lock(mutex_);
  return last_;
}

}  // namespace densemap::client
