// A participant on Eclipse Cyclone DDS (Debian 12's 0.10, the DDS under rmw_cyclonedds_cpp), written
// against its C API as a robot, tool or ROS 2 node on Cyclone would be, for the interoperability tests.
// Loopback only: UDP on 127.0.0.1, discovery by unicast to this host's participants (no multicast).
#pragma once

#include <dds/dds.h>

#include <chrono>
#include <deque>
#include <functional>
#include <stdexcept>
#include <string>
#include <thread>

namespace densemap::test::cyclone {

/// Cyclone's configuration for a test on loopback: the same as CYCLONEDDS_URI would give ddsperf.
inline std::string loopbackConfig() {
  return "<CycloneDDS><Domain Id=\"any\"><General><Interfaces><NetworkInterface address=\"127.0.0.1\"/>"
         "</Interfaces><AllowMulticast>false</AllowMulticast></General>"
         // The map topics are megabytes: Cyclone's default receive buffer (the kernel's 208 KiB) overflows
         // and a lost fragment of Fast DDS 2.9's sample was not repaired (the ROS 2 documentation's advice
         // for large messages on Cyclone: a bigger SocketReceiveBufferSize).
         "<Internal><SocketReceiveBufferSize min=\"8MB\"/></Internal><Discovery>"
         "<ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>40</MaxAutoParticipantIndex>"
         "<Peers><Peer address=\"127.0.0.1\"/></Peers></Discovery></Domain></CycloneDDS>";
}

struct Qos {
  bool reliable = true;
  bool transient_local = false;
  bool keep_all = false;
  int depth = 10;
};

class Node {
 public:
  explicit Node(int domain) {
    const std::string config = loopbackConfig();
    domain_ = dds_create_domain(static_cast<dds_domainid_t>(domain), config.c_str());
    if (domain_ < 0) throw std::runtime_error(std::string("dds_create_domain: ") + dds_strretcode(domain_));
    participant_ = dds_create_participant(static_cast<dds_domainid_t>(domain), nullptr, nullptr);
    if (participant_ < 0)
      throw std::runtime_error(std::string("dds_create_participant: ") + dds_strretcode(participant_));
  }
  ~Node() { dds_delete(domain_); }
  Node(const Node&) = delete;
  Node& operator=(const Node&) = delete;

  /// A topic of the generated type `desc`, registered under `type_name` when given (a layout whose DDS type
  /// name is not its IDL name, e.g. rmw_cyclonedds' framed service types).
  dds_entity_t topic(const dds_topic_descriptor_t* desc, const std::string& name,
                     const char* type_name = nullptr) {
    if (type_name != nullptr) {
      renamed_.push_back(*desc);  // Cyclone may keep the descriptor: it lives as long as the node
      renamed_.back().m_typename = type_name;
      desc = &renamed_.back();
    }
    const dds_entity_t t = dds_create_topic(participant_, desc, name.c_str(), nullptr, nullptr);
    if (t < 0) throw std::runtime_error("dds_create_topic " + name + ": " + dds_strretcode(t));
    return t;
  }
  dds_entity_t writer(dds_entity_t topic, const Qos& q) {
    dds_qos_t* qos = make(q);
    const dds_entity_t w = dds_create_writer(participant_, topic, qos, nullptr);
    dds_delete_qos(qos);
    if (w < 0) throw std::runtime_error(std::string("dds_create_writer: ") + dds_strretcode(w));
    return w;
  }
  dds_entity_t reader(dds_entity_t topic, const Qos& q) {
    dds_qos_t* qos = make(q);
    const dds_entity_t r = dds_create_reader(participant_, topic, qos, nullptr);
    dds_delete_qos(qos);
    if (r < 0) throw std::runtime_error(std::string("dds_create_reader: ") + dds_strretcode(r));
    return r;
  }
  dds_entity_t participant() const { return participant_; }

 private:
  static dds_qos_t* make(const Qos& q) {
    dds_qos_t* qos = dds_create_qos();
    dds_qset_reliability(qos, q.reliable ? DDS_RELIABILITY_RELIABLE : DDS_RELIABILITY_BEST_EFFORT,
                         DDS_SECS(10));
    dds_qset_durability(qos, q.transient_local ? DDS_DURABILITY_TRANSIENT_LOCAL : DDS_DURABILITY_VOLATILE);
    dds_qset_history(qos, q.keep_all ? DDS_HISTORY_KEEP_ALL : DDS_HISTORY_KEEP_LAST, q.depth);
    return qos;
  }
  dds_entity_t domain_ = 0;
  dds_entity_t participant_ = 0;
  std::deque<dds_topic_descriptor_t> renamed_;
};

inline int matched(dds_entity_t entity) {
  dds_publication_matched_status_t p{};
  if (dds_get_publication_matched_status(entity, &p) == DDS_RETCODE_OK)
    return static_cast<int>(p.current_count);
  dds_subscription_matched_status_t s{};
  if (dds_get_subscription_matched_status(entity, &s) == DDS_RETCODE_OK)
    return static_cast<int>(s.current_count);
  return 0;
}

/// Until `entity` (a writer or a reader) has matched at least `n` peers, or `timeout`.
inline bool waitMatched(dds_entity_t entity, int n = 1,
                        std::chrono::milliseconds timeout = std::chrono::milliseconds(20000)) {
  const auto until = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < until) {
    if (matched(entity) >= n) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return false;
}

/// Takes the next sample within `timeout` and hands it to `use` (valid only during the call); false when
/// none came.
template <class T>
bool takeOne(dds_entity_t reader, std::chrono::milliseconds timeout,
             const std::function<void(const T&)>& use) {
  const auto until = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < until) {
    void* samples[1] = {nullptr};
    dds_sample_info_t info[1];
    const dds_return_t n = dds_take(reader, samples, info, 1, 1);
    if (n > 0) {
      const bool valid = info[0].valid_data;
      if (valid) use(*static_cast<const T*>(samples[0]));
      dds_return_loan(reader, samples, n);
      if (valid) return true;
      continue;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return false;
}

/// A Cyclone sequence viewing `data` (not released by Cyclone).
template <class Seq, class T>
Seq viewOf(T* data, std::size_t n) {
  Seq s{};
  s._maximum = s._length = static_cast<std::uint32_t>(n);
  s._buffer = data;
  s._release = false;
  return s;
}

}  // namespace densemap::test::cyclone
