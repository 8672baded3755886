#include "densemap/msg/dds_node.h"
#include "densemap/util/wall_clock.h"

#include <algorithm>
#include <chrono>
#include <mutex>
#include <set>
#include <sstream>
#include <string_view>

#include <fastdds/rtps/common/Locator.h>
#include <fastrtps/utils/IPLocator.h>
#include <spdlog/spdlog.h>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>

namespace densemap::msg {

extern const char* const kEmbeddedProfilesXml;

namespace dds = eprosima::fastdds::dds;

namespace {

// Profiles are process-wide in Fast DDS: load them once (the first node's choice wins).
void loadProfiles(const std::string& file) {
  static std::once_flag once;
  static std::string loaded;
  static bool ok = false;
  std::call_once(once, [&] {
    auto* factory = dds::DomainParticipantFactory::get_instance();
    if (file.empty()) {
      const std::string xml = kEmbeddedProfilesXml;
      ok = factory->load_XML_profiles_string(xml.c_str(), xml.size()) == ReturnCode_t::RETCODE_OK;
      loaded = "built-in profiles";
    } else {
      ok = factory->load_XML_profiles_file(file) == ReturnCode_t::RETCODE_OK;
      loaded = file;
    }
  });
  if (!ok) {
    throw DdsError("could not load the DDS XML profiles from " + loaded +
                   " (check the file against config/dds_profiles.xml)");
  }
}

// Initial peers and multicast (RTPS discovery, Fast DDS "disable multicast" use case): a peer locator with
// port 0 stands for the domain's unicast discovery ports of participant ids 0..3 on that host.
void configureDiscovery(const DdsOptions& options, dds::DomainParticipantQos& qos) {
  namespace rtps = eprosima::fastrtps::rtps;
  auto& builtin = qos.wire_protocol().builtin;
  auto peer = [](const std::string& address, std::uint32_t port) {
    rtps::Locator_t l;
    l.kind = LOCATOR_KIND_UDPv4;
    rtps::IPLocator::setIPv4(l, address);
    l.port = port;
    return l;
  };
  if (!options.peers.empty() || options.no_multicast) {
    // A non-empty list replaces Fast DDS's default one (the multicast group): say what we still want.
    for (const auto& p : options.peers) builtin.initialPeersList.push_back(peer(p, 0));
    if (options.no_multicast) {
      builtin.initialPeersList.push_back(peer("127.0.0.1", 0));  // participants on this host
    } else {
      const auto multicast_port = static_cast<std::uint32_t>(7400 + 250 * options.domain);
      builtin.initialPeersList.push_back(peer("239.255.0.1", multicast_port));
    }
  }
  if (options.lease_s > 0) {
    // Announce four times per lease (Fast DDS by default: every 3 s, lease 20 s), so one lost announcement
    // does not end it.
    builtin.discovery_config.leaseDuration = eprosima::fastrtps::Duration_t(options.lease_s);
    builtin.discovery_config.leaseDuration_announcementperiod =
        eprosima::fastrtps::Duration_t(options.lease_s / 4);
  }
  if (options.no_multicast) {
    // An explicit unicast listening locator (any address, well-known port) means no multicast listener.
    rtps::Locator_t any;
    any.kind = LOCATOR_KIND_UDPv4;
    any.port = 0;
    builtin.metatrafficUnicastLocatorList.clear();
    builtin.metatrafficUnicastLocatorList.push_back(any);
    builtin.metatrafficMulticastLocatorList.clear();
  }
}

}  // namespace

bool matchedBothWays(eprosima::fastdds::dds::DataWriter& writer, eprosima::fastdds::dds::DataReader& reader) {
  eprosima::fastdds::dds::PublicationMatchedStatus pub;
  eprosima::fastdds::dds::SubscriptionMatchedStatus sub;
  writer.get_publication_matched_status(pub);
  reader.get_subscription_matched_status(sub);
  return pub.current_count > 0 && sub.current_count > 0;
}

std::int64_t nowNs() { return util::wallClockNs(); }

namespace {

constexpr std::string_view kServerAnnouncement = "densemap-server;namespace=";

struct PresenceRecord {
  std::mutex mutex;
  std::set<std::string> server_guids;
  std::set<std::string> refused_guids;
  std::set<std::string> namespaces;
};
PresenceRecord& presenceRecord() {
  static PresenceRecord record;
  return record;
}
// Past this many, a flood of new participants is no longer remembered (the counts stay lower bounds).
constexpr std::size_t kMaxRemembered = 1024;

std::string guidOf(const eprosima::fastrtps::rtps::GUID_t& guid) {
  std::ostringstream s;
  s << guid.guidPrefix;
  return s.str();
}

}  // namespace

DomainPresence domainPresenceInProcess() {
  PresenceRecord& r = presenceRecord();
  std::lock_guard lock(r.mutex);
  return {r.server_guids.size(), {r.namespaces.begin(), r.namespaces.end()}, r.refused_guids.size()};
}

// A client that sees no server must say why: a server that is there but matches nothing (another
// namespace, or it did not admit this identity) is told apart from none at all.
class DdsNode::PresenceWatch : public dds::DomainParticipantListener {
 public:
  void on_participant_discovery(dds::DomainParticipant*,
                                eprosima::fastrtps::rtps::ParticipantDiscoveryInfo&& info) override {
    if (info.status != eprosima::fastrtps::rtps::ParticipantDiscoveryInfo::DISCOVERED_PARTICIPANT) return;
    const auto& bytes = info.info.m_userData.data_vec();
    const std::string announced(bytes.begin(), bytes.end());
    if (announced.rfind(kServerAnnouncement, 0) != 0) return;
    PresenceRecord& r = presenceRecord();
    std::lock_guard lock(r.mutex);
    if (r.server_guids.size() < kMaxRemembered) r.server_guids.insert(guidOf(info.info.m_guid));
    if (r.namespaces.size() < 16) r.namespaces.insert(announced.substr(kServerAnnouncement.size()));
  }
  void onParticipantAuthentication(dds::DomainParticipant*,
                                   eprosima::fastrtps::rtps::ParticipantAuthenticationInfo&& info) override {
    if (info.status != eprosima::fastrtps::rtps::ParticipantAuthenticationInfo::UNAUTHORIZED_PARTICIPANT)
      return;
    const std::string guid = guidOf(info.guid);
    PresenceRecord& r = presenceRecord();
    {
      std::lock_guard lock(r.mutex);  // Fast DDS retries a failed handshake: each participant counts once
      if (r.refused_guids.size() >= kMaxRemembered || !r.refused_guids.insert(guid).second) return;
    }
    spdlog::warn(
        "DDS-Security: authentication with participant {} failed (another CA, or a certificate expired or "
        "revoked on either side): it will not match this program",
        guid);
  }
};

DdsNode::DdsNode(const DdsOptions& options, dds::DomainParticipantListener* discovery) {
  if (options.domain < 0 || options.domain > 232) {
    throw DdsError("DDS domain id " + std::to_string(options.domain) + " is out of range (0..232)");
  }
  if (const std::string why = checkTopicNamespace(options.topic_namespace); !why.empty()) throw DdsError(why);
  namespace_ = options.topic_namespace;
  loadProfiles(options.profile_file);
  auto* factory = dds::DomainParticipantFactory::get_instance();
  const std::string profile = options.loopback
                                  ? (options.udp_only ? "densemap_loopback_udp" : "densemap_loopback")
                              : options.udp_only ? "densemap_udp"
                                                 : "densemap";
  dds::DomainParticipantQos qos;
  if (factory->get_participant_qos_from_profile(profile, qos) != ReturnCode_t::RETCODE_OK) {
    throw DdsError("the DDS profiles have no participant profile '" + profile + "'");
  }
  qos.name(options.name);
  configureDiscovery(options, qos);
  if (!options.security_dir.empty()) {
    identity_ = checkSecurityFolder(options.security_dir);
    applySecurity(identity_, qos);
  }
  if (options.announce_server) {
    const std::string announced = std::string(kServerAnnouncement) + options.topic_namespace;
    qos.user_data().data_vec({announced.begin(), announced.end()});
  }
  if (discovery == nullptr) {
    watch_ = std::make_unique<PresenceWatch>();
    discovery = watch_.get();
  }
  participant_ = factory->create_participant(static_cast<dds::DomainId_t>(options.domain), qos, discovery,
                                             dds::StatusMask::none());
  if (participant_ == nullptr) {
    throw DdsError(
        "could not create a DDS participant on domain " + std::to_string(options.domain) +
        (secure() ? " with the identity in " + identity_.dir +
                        " (Fast DDS's [SECURITY] lines above say why: permissions that do not grant this "
                        "domain, or an unreadable file)"
                  : " (is /dev/shm writable and large enough?)"));
  }
  publisher_ = participant_->create_publisher(dds::PUBLISHER_QOS_DEFAULT);
  subscriber_ = participant_->create_subscriber(dds::SUBSCRIBER_QOS_DEFAULT);
  if (publisher_ == nullptr || subscriber_ == nullptr) {
    close();
    throw DdsError("could not create the DDS publisher or subscriber");
  }
}

DdsNode::~DdsNode() { close(); }

void DdsNode::close() {
  std::lock_guard lock(mutex_);
  if (participant_ == nullptr) return;
  participant_->set_listener(nullptr);
  participant_->delete_contained_entities();
  dds::DomainParticipantFactory::get_instance()->delete_participant(participant_);
  participant_ = nullptr;
  publisher_ = nullptr;
  subscriber_ = nullptr;
  topics_.clear();
}

void DdsNode::remove(dds::DataReader* reader) {
  std::lock_guard lock(mutex_);
  if (participant_ != nullptr && reader != nullptr) subscriber_->delete_datareader(reader);
}

void DdsNode::remove(dds::DataWriter* writer) {
  std::lock_guard lock(mutex_);
  if (participant_ != nullptr && writer != nullptr) publisher_->delete_datawriter(writer);
}

std::string DdsNode::refusedBecause(const std::string& verb, const std::string& topic) const {
  if (!secure()) return "";
  return ": the identity '" + identity_.name + "' (" + identity_.dir + ") may not " + verb + " " + topic +
         " (its permissions.xml does not grant it: this program needs another role's identity)";
}

std::string DdsNode::topicName(const std::string& base_name) const {
  return namespace_.empty() ? base_name : namespace_ + "/" + base_name;
}

dds::Topic* DdsNode::topic(const std::string& base_name, dds::TypeSupport type) {
  const std::string name = topicName(base_name);
  std::lock_guard lock(mutex_);
  if (auto it = topics_.find(name); it != topics_.end()) return it->second;
  if (participant_->find_type(type.get_type_name()).empty()) {
    if (type.register_type(participant_) != ReturnCode_t::RETCODE_OK) {
      throw DdsError("could not register DDS type " + type.get_type_name());
    }
  }
  dds::Topic* t = participant_->create_topic(name, type.get_type_name(), dds::TOPIC_QOS_DEFAULT);
  if (t == nullptr) throw DdsError("could not create DDS topic " + name);
  topics_[name] = t;
  return t;
}

dds::DataWriter* DdsNode::writer(dds::Topic* topic, const std::string& profile,
                                 dds::DataWriterListener* listener) {
  dds::DataWriter* w = publisher_->create_datawriter_with_profile(topic, profile, listener);
  if (w == nullptr)
    throw DdsError("could not create a DDS writer on " + topic->get_name() + " (profile " + profile + ")" +
                   refusedBecause("publish", topic->get_name()));
  return w;
}

dds::DataReader* DdsNode::reader(dds::TopicDescription* topic, const std::string& profile,
                                 dds::DataReaderListener* listener) {
  dds::DataReader* r = subscriber_->create_datareader_with_profile(topic, profile, listener);
  if (r == nullptr)
    throw DdsError("could not create a DDS reader on " + topic->get_name() + " (profile " + profile + ")" +
                   refusedBecause("subscribe to", topic->get_name()));
  return r;
}

dds::DataWriter* DdsNode::writer(dds::Topic* topic, const dds::DataWriterQos& qos,
                                 dds::DataWriterListener* listener) {
  dds::DataWriter* w = publisher_->create_datawriter(topic, qos, listener);
  if (w == nullptr)
    throw DdsError("could not create a DDS writer on " + topic->get_name() +
                   refusedBecause("publish", topic->get_name()));
  return w;
}

dds::DataReader* DdsNode::reader(dds::TopicDescription* topic, const dds::DataReaderQos& qos,
                                 dds::DataReaderListener* listener) {
  dds::DataReader* r = subscriber_->create_datareader(topic, qos, listener);
  if (r == nullptr)
    throw DdsError("could not create a DDS reader on " + topic->get_name() +
                   refusedBecause("subscribe to", topic->get_name()));
  return r;
}

namespace {

// The progress topic's QoS, the same on both sides so they match: reliable, and transient local with
// the newest sample kept, so a robot that (re)connects reads what the server holds at once.
template <typename Qos>
Qos progressQos(Qos q) {
  q.reliability().kind = dds::RELIABLE_RELIABILITY_QOS;
  q.durability().kind = dds::TRANSIENT_LOCAL_DURABILITY_QOS;
  q.history().kind = dds::KEEP_LAST_HISTORY_QOS;
  q.history().depth = 1;
  q.endpoint().history_memory_policy = eprosima::fastrtps::rtps::DYNAMIC_REUSABLE_MEMORY_MODE;
  return q;
}

}  // namespace

dds::DataWriterQos progressWriterQos() {
  return progressQos(dds::DataWriterQos(dds::DATAWRITER_QOS_DEFAULT));
}

dds::DataReaderQos progressReaderQos() {
  return progressQos(dds::DataReaderQos(dds::DATAREADER_QOS_DEFAULT));
}

std::string describeTransport(const DdsOptions& options) {
  if (!options.profile_file.empty()) return "the transports of the profile file " + options.profile_file;
  std::string t = options.udp_only ? "UDP" : "shared memory + UDP";
  t += options.loopback ? " on 127.0.0.1 (--loopback)" : " on every interface";
  if (options.udp_only) t += " (--udp-only)";
  if (!options.peers.empty()) {
    t += ", peers";
    for (const std::string& p : options.peers) t += " " + p;
  }
  t += options.no_multicast ? ", no multicast discovery" : ", multicast discovery";
  return t;
}

}  // namespace densemap::msg
