// One DDS participant with its publisher and subscriber, configured from densemap's XML profiles
// (config/dds_profiles.xml, compiled in). Shared by the server and the clients.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <vector>

#include <fastdds/dds/core/policy/QosPolicies.hpp>
#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantListener.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/Topic.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>

#include "densemap/msg/checked_type.h"
#include "densemap/msg/dds_security.h"
#include "densemap/msg/topic_namespace.h"

namespace densemap::msg {

/// Topic names.
inline constexpr const char* kScanTopic = "densemap/scans";
inline constexpr const char* kScanAckTopic = "densemap/scan_acks";
inline constexpr const char* kQueryRequestTopic = "densemap/query/request";
inline constexpr const char* kQueryReplyTopic = "densemap/query/reply";
inline constexpr const char* kAdminRequestTopic = "densemap/admin/request";
inline constexpr const char* kAdminReplyTopic = "densemap/admin/reply";
inline constexpr const char* kStatisticsTopic = "densemap/statistics";
inline constexpr const char* kRobotProgressTopic = "densemap/robot_progress";

/// Profile names in config/dds_profiles.xml.
inline constexpr const char* kScanWriterProfile = "scan_writer";
inline constexpr const char* kScanReaderProfile = "scan_reader";
inline constexpr const char* kMessageWriterProfile = "message_writer";
inline constexpr const char* kMessageReaderProfile = "message_reader";
/// Query and admin replies: as message_writer, with a lifespan (kReplyLifespanS) after which a reply leaves
/// the history, so large replies do not stay pinned in it until 256 later ones replace them.
inline constexpr const char* kReplyWriterProfile = "reply_writer";
inline constexpr double kReplyLifespanS = 10.0;

/// densemap/robot_progress: reliable, transient local, the last sample kept, so a robot that connects
/// later still reads the latest one.
eprosima::fastdds::dds::DataWriterQos progressWriterQos();
eprosima::fastdds::dds::DataReaderQos progressReaderQos();

struct DdsOptions {
  /// DDS domain id (every program takes --domain N).
  int domain = 0;
  /// Shared memory + UDP on 127.0.0.1 only (profile "densemap_loopback") instead of every interface.
  bool loopback = false;
  /// UDP only, no shared memory (profile "densemap_udp"): between containers, whose /dev/shm and network
  /// namespaces differ. With `loopback`: UDP on 127.0.0.1 only (profile "densemap_loopback_udp").
  bool udp_only = false;
  /// An XML profile file to load instead of the built-in one (same profile names); empty: built-in.
  std::string profile_file;
  /// Initial discovery peers (IPv4 addresses): participants there are asked directly, by unicast, on the
  /// domain's well-known ports for participant ids 0..3. Multicast discovery stays on unless `no_multicast`.
  std::vector<std::string> peers;
  /// No multicast discovery: only `peers` and this host are asked (networks that block multicast).
  bool no_multicast = false;
  /// Participant lease duration in seconds (0: Fast DDS's 20 s, also ROS 2's). A peer silent this long is
  /// dropped: a shorter lease lets robots give up a crashed server sooner (their reliable scan writer waits
  /// for its acknowledgements until then) but drops peers behind shorter network outages.
  double lease_s = 0.0;
  /// Participant name, shown by DDS tools.
  std::string name = "densemap";
  /// Prefixes every topic ("fleet_a" -> "fleet_a/densemap/scans"), so independent maps share a domain:
  /// one server per namespace. Empty: the plain topic names.
  std::string topic_namespace;
  /// DDS-Security: an identity folder (tools/make-security.sh DIR/<identity>, or an SROS2 enclave). Empty:
  /// plain DDS, unauthenticated and unencrypted.
  std::string security_dir;
  /// A densemap server's participant announces itself (and its namespace) in its discovery data, so a
  /// client that finds a server but matches none of its topics can say why instead of "no server".
  bool announce_server = false;
};

/// What the secure and plain nodes of this process (those made without a discovery listener of their own:
/// clients) saw of the domain: servers that announced themselves, and participants whose authentication
/// with this process's identity failed. Kept across replaced nodes.
struct DomainPresence {
  std::uint64_t servers_seen = 0;              ///< densemap server participants discovered (each once)
  std::vector<std::string> server_namespaces;  ///< their namespaces, as announced (empty: none)
  std::uint64_t authentication_failures = 0;
};
[[nodiscard]] DomainPresence domainPresenceInProcess();

class DdsError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class DdsNode {
 public:
  /// Throws DdsError when the profiles cannot be loaded or the participant cannot be created.
  /// `discovery`: told of every remote participant, reader and writer from the start (no entity statuses);
  /// it must outlive the node or be removed by close().
  explicit DdsNode(const DdsOptions& options,
                   eprosima::fastdds::dds::DomainParticipantListener* discovery = nullptr);
  ~DdsNode();
  DdsNode(const DdsNode&) = delete;
  DdsNode& operator=(const DdsNode&) = delete;

  eprosima::fastdds::dds::DomainParticipant& participant() { return *participant_; }
  /// The participant's identity in secure mode; empty name in plain mode.
  const SecurityIdentity& identity() const { return identity_; }
  bool secure() const { return !identity_.dir.empty(); }
  /// The topic name as it is on the wire: under the node's namespace.
  std::string topicName(const std::string& base_name) const;

  /// Registers the type on first use and returns the topic (one per name), under the node's namespace.
  eprosima::fastdds::dds::Topic* topic(const std::string& name, eprosima::fastdds::dds::TypeSupport type);
  eprosima::fastdds::dds::DataWriter* writer(eprosima::fastdds::dds::Topic* topic, const std::string& profile,
                                             eprosima::fastdds::dds::DataWriterListener* listener = nullptr);
  eprosima::fastdds::dds::DataReader* reader(eprosima::fastdds::dds::TopicDescription* topic,
                                             const std::string& profile,
                                             eprosima::fastdds::dds::DataReaderListener* listener);

  /// A writer / reader with explicit QoS (ROS 2 topics, whose QoS come from ROS 2's profiles, not ours).
  eprosima::fastdds::dds::DataWriter* writer(eprosima::fastdds::dds::Topic* topic,
                                             const eprosima::fastdds::dds::DataWriterQos& qos,
                                             eprosima::fastdds::dds::DataWriterListener* listener = nullptr);
  eprosima::fastdds::dds::DataReader* reader(eprosima::fastdds::dds::TopicDescription* topic,
                                             const eprosima::fastdds::dds::DataReaderQos& qos,
                                             eprosima::fastdds::dds::DataReaderListener* listener);

  /// Deletes a reader or writer this node created (waits for a listener call in progress to return).
  void remove(eprosima::fastdds::dds::DataReader* reader);
  void remove(eprosima::fastdds::dds::DataWriter* writer);

  /// Removes every listener-carrying entity (call before the listeners are destroyed).
  void close();

 private:
  class PresenceWatch;
  std::unique_ptr<PresenceWatch> watch_;  // outlives participant_: close() detaches it first
  eprosima::fastdds::dds::DomainParticipant* participant_ = nullptr;
  eprosima::fastdds::dds::Publisher* publisher_ = nullptr;
  eprosima::fastdds::dds::Subscriber* subscriber_ = nullptr;
  std::mutex mutex_;  // topic creation from several threads (e.g. query clients started in parallel)
  std::map<std::string, eprosima::fastdds::dds::Topic*> topics_;
  std::string refusedBecause(const std::string& verb, const std::string& topic) const;

  std::string namespace_;
  SecurityIdentity identity_;
};

/// The type support of a generated PubSubType, with a decoder that refuses malformed samples instead of
/// throwing (checked_type.h). Fast DDS takes ownership through a raw pointer; make_unique + release keeps
/// `new` out of our code and the hand-over in one place.
template <class PubSubType>
eprosima::fastdds::dds::TypeSupport typeSupport() {
  return eprosima::fastdds::dds::TypeSupport(std::make_unique<CheckedType<PubSubType>>().release());
}

/// True when `writer` has matched a reader and `reader` a writer: our side of a request-reply pair sees a
/// peer. Matching is not symmetric, so the peer may not see us yet (the clients' waitForServer handles that).
bool matchedBothWays(eprosima::fastdds::dds::DataWriter& writer, eprosima::fastdds::dds::DataReader& reader);

/// The transport `options` choose, in words (for what a program says it waits on): e.g. "shared memory +
/// UDP on 127.0.0.1 (--loopback)".
[[nodiscard]] std::string describeTransport(const DdsOptions& options);

/// System clock in nanoseconds (the clock scan stamps and latencies use; hosts are assumed NTP-synced).
std::int64_t nowNs();

}  // namespace densemap::msg
