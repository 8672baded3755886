#include "densemap/client/query_client.h"

#include <thread>

#include <spdlog/spdlog.h>
#include <fastdds/dds/publisher/DataWriterListener.hpp>
#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>

#include "densemap/msg/densemapPubSubTypes.h"

namespace densemap::client {

namespace dds = eprosima::fastdds::dds;

class QueryClient::Listener : public dds::DataReaderListener {
 public:
  explicit Listener(QueryClient& c) : c_(c) {}
  // Use the reader passed in: replies can arrive before create_datareader() has returned (intraprocess).
  void on_data_available(dds::DataReader* reader) override { c_.onReplies(reader); }

 private:
  QueryClient& c_;
};

QueryClient::QueryClient(msg::DdsNode& node, std::string client_id) : node_(node), id_(std::move(client_id)) {
  listener_ = std::make_unique<Listener>(*this);
  auto* requests = node_.topic(msg::kQueryRequestTopic, msg::typeSupport<msg::QueryRequestPubSubType>());
  auto* replies = node_.topic(msg::kQueryReplyTopic, msg::typeSupport<msg::QueryReplyPubSubType>());
  writer_ = node_.writer(requests, msg::kMessageWriterProfile);
  // Replies to other clients are skipped here by client_id. (A DDS SQL content filter would do it on the
  // writer's side, but Fast DDS 2.9 evaluates it on a dynamic-type copy of the sample, which took seconds
  // per 1 MB reply and stalled the server's writer.)
  reader_ = node_.reader(replies, msg::kMessageReaderProfile, listener_.get());
}

QueryClient::~QueryClient() {
  // Stop callbacks before the listener goes away.
  node_.remove(reader_);
  node_.remove(writer_);
}

bool QueryClient::waitForServer(std::chrono::milliseconds timeout) {
  // Matching is not symmetric: our endpoints may know the server's before the server's know ours, and
  // until then requests or replies are lost. A cheap probe (an empty point query) that comes back proves
  // both directions work.
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < deadline) {
    if (msg::matchedBothWays(*writer_, *reader_)) {
      msg::QueryRequest probe;
      probe.kind(msg::QUERY_POINTS);
      try {
        call(probe, std::chrono::milliseconds(250));
        return true;
      } catch (const QueryTimeout&) {
        continue;
      }
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return false;
}

msg::QueryReply QueryClient::call(msg::QueryRequest request, std::chrono::milliseconds timeout) {
  std::future<msg::QueryReply> reply;
  {
    std::lock_guard lock(mutex_);
    request.client_id(id_);
    request.request_id(next_id_++);
    reply = pending_[request.request_id()].get_future();
  }
  writer_->write(&request);
  if (reply.wait_for(timeout) != std::future_status::ready) {
    std::lock_guard lock(mutex_);
    pending_.erase(request.request_id());
    throw QueryTimeout("no reply to query " + std::to_string(request.request_id()) + " within " +
                       std::to_string(timeout.count()) + " ms (is densemap-server running on this domain?)");
  }
  return reply.get();
}

void QueryClient::onReplies(dds::DataReader* reader) {
  msg::QueryReply rp;
  dds::SampleInfo info;
  while (reader->take_next_sample(&rp, &info) == ReturnCode_t::RETCODE_OK) {
    if (!info.valid_data || rp.client_id() != id_) continue;
    std::lock_guard lock(mutex_);
    auto it = pending_.find(rp.request_id());
    if (it == pending_.end()) continue;  // a reply that came after its timeout
    it->second.set_value(std::move(rp));
    pending_.erase(it);
    rp = msg::QueryReply();
  }
}

msg::QueryRequest boxRequest(msg::QueryKind kind, const std::array<float, 3>& lo,
                             const std::array<float, 3>& hi) {
  msg::QueryRequest rq;
  rq.kind(kind);
  rq.box_min(lo);
  rq.box_max(hi);
  return rq;
}

std::string toString(msg::QueryStatus s) {
  switch (s) {
    case msg::STATUS_OK:
      return "ok";
    case msg::STATUS_INVALID_ARGUMENT:
      return "invalid argument";
    case msg::STATUS_UNKNOWN_KIND:
      return "unknown query kind";
    case msg::STATUS_LAYER_UNAVAILABLE:
      return "layer unavailable";
    case msg::STATUS_FAILED:
      return "failed";
  }
  return "status " + std::to_string(static_cast<unsigned>(s));
}

std::string toString(msg::ScanOutcome o) {
  switch (o) {
    case msg::SCAN_APPLIED:
      return "applied";
    case msg::SCAN_REJECTED:
      return "rejected";
    case msg::SCAN_DROPPED:
      return "dropped";
  }
  return "outcome " + std::to_string(static_cast<unsigned>(o));
}

}  // namespace densemap::client
