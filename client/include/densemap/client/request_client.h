// Request-reply over DDS, for any request/reply pair of densemap's (queries, admin commands): sends a
// request with this client's id and waits for the matching reply on this client's own reply topic
// (peer_topic.h). Safe to call from several threads at once.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <future>
#include <map>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>

#include <fastdds/dds/core/status/PublicationMatchedStatus.hpp>
#include <fastdds/dds/core/status/SubscriptionMatchedStatus.hpp>
#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>

#include "densemap/client/server_join.h"
#include "densemap/msg/dds_node.h"
#include "densemap/msg/peer_topic.h"

namespace densemap::client {

class QueryTimeout : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// `Request` and `Reply` are generated types with client_id and request_id; the PubSubTypes their type
/// support.
template <class Request, class Reply, class RequestPubSub, class ReplyPubSub>
class RequestClient {
 public:
  /// `probe`: a request that changes nothing, sent by waitForServer() to prove both directions work.
  RequestClient(msg::DdsNode& node, std::string client_id, const char* request_topic, const char* reply_topic,
                Request probe)
      : node_(node), id_(std::move(client_id)), probe_(std::move(probe)) {
    if (const std::string why = msg::checkPeerId(id_); !why.empty()) throw std::invalid_argument(why);
    listener_ = std::make_unique<Listener>(*this);
    auto* requests = node_.topic(request_topic, msg::typeSupport<RequestPubSub>());
    // Our own reply topic: the server makes its writer when it discovers this reader (or at our first
    // request). A topic per client rather than a DDS content filter: the permissions can name it, and
    // Fast DDS 2.9 evaluated a filter on a dynamic-type copy of each sample (seconds per 1 MB reply).
    auto* replies = node_.topic(msg::peerTopicOf(reply_topic, id_), msg::typeSupport<ReplyPubSub>());
    // The reply reader first: an identity is refused a client id not its own there, and a role without
    // this service is refused both, so a refusal throws before anything exists (deleting a fresh secure
    // endpoint mid key exchange can crash Fast DDS 2.9: see ScanPublisher's constructor).
    reader_ = node_.reader(replies, msg::kMessageReaderProfile, listener_.get());
    try {
      writer_ = node_.writer(requests, msg::kMessageWriterProfile);
    } catch (...) {
      node_.remove(reader_);  // no destructor runs for a constructor that throws
      throw;
    }
  }
  ~RequestClient() {
    // Stop callbacks before the listener goes away.
    node_.remove(reader_);
    node_.remove(writer_);
  }
  RequestClient(const RequestClient&) = delete;
  RequestClient& operator=(const RequestClient&) = delete;

  /// Waits until a server answers the probe; false on timeout. Matching is not symmetric: our endpoints
  /// may know the server's before the server's know ours, and until then requests or replies are lost,
  /// so only a reply proves both directions.
  bool waitForServer(std::chrono::milliseconds timeout) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < deadline) {
      if (msg::matchedBothWays(*writer_, *reader_)) {
        try {
          call(probe_, std::chrono::milliseconds(250));
          return true;
        } catch (const QueryTimeout&) {
          continue;
        }
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return false;
  }

  /// What waitForServer is still waiting for (for the message when it times out).
  std::string joinState() {
    eprosima::fastdds::dds::PublicationMatchedStatus pub;
    eprosima::fastdds::dds::SubscriptionMatchedStatus sub;
    writer_->get_publication_matched_status(pub);
    reader_->get_subscription_matched_status(sub);
    std::string out = id_ + ": requests read by " + std::to_string(pub.current_count) +
                      " server reader(s), replies from " + std::to_string(sub.current_count) +
                      " server writer(s)";
    if (node_.secure()) {
      out += kUnauthenticatedHint;
    }
    return out;
  }

  /// Sends the request (client_id and request_id are filled in) and returns the reply. Throws QueryTimeout.
  Reply call(Request request, std::chrono::milliseconds timeout = std::chrono::seconds(10)) {
    std::future<Reply> reply;
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
      throw QueryTimeout("no reply to request " + std::to_string(request.request_id()) + " within " +
                         std::to_string(timeout.count()) +
                         " ms (is densemap-server running on this domain?)");
    }
    return reply.get();
  }

  const std::string& id() const { return id_; }

 private:
  class Listener : public eprosima::fastdds::dds::DataReaderListener {
   public:
    explicit Listener(RequestClient& c) : c_(c) {}
    // Use the reader passed in: replies can arrive before create_datareader() has returned (intraprocess).
    void on_data_available(eprosima::fastdds::dds::DataReader* reader) override { c_.onReplies(reader); }

   private:
    RequestClient& c_;
  };

  void onReplies(eprosima::fastdds::dds::DataReader* reader) {
    Reply rp;
    eprosima::fastdds::dds::SampleInfo info;
    while (reader->take_next_sample(&rp, &info) == ReturnCode_t::RETCODE_OK) {
      if (!info.valid_data || rp.client_id() != id_) continue;
      std::lock_guard lock(mutex_);
      auto it = pending_.find(rp.request_id());
      if (it == pending_.end()) continue;  // a reply that came after its timeout
      it->second.set_value(std::move(rp));
      pending_.erase(it);
      rp = Reply();
    }
  }

  msg::DdsNode& node_;
  std::string id_;
  Request probe_;
  std::unique_ptr<Listener> listener_;
  eprosima::fastdds::dds::DataWriter* writer_ = nullptr;
  eprosima::fastdds::dds::DataReader* reader_ = nullptr;
  std::mutex mutex_;
  std::uint64_t next_id_ = 1;
  std::map<std::uint64_t, std::promise<Reply>> pending_;
};

}  // namespace densemap::client
