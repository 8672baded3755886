#include "densemap/msg/dds_options_cli.h"

#include <filesystem>

namespace densemap::msg {

options::OptionTable ddsOptions(DdsOptions& o) {
  options::OptionTable t("DDS");
  t.add("domain", o.domain, "DDS domain id (UDP ports 7400 + 250 * domain and up)").range(0, 232);
  t.add("loopback", o.loopback, "DDS on this host only (shared memory + UDP on 127.0.0.1)");
  t.add("udp-only", o.udp_only,
        "UDP only, no shared memory (containers or hosts that do not share /dev/shm; with --loopback: UDP on "
        "127.0.0.1)");
  t.add("dds-profile", o.profile_file,
        "Fast DDS XML profile file instead of the built-in one (empty: built in)")
      .checkedBy([&o] {
        return o.profile_file.empty() || std::filesystem::is_regular_file(o.profile_file)
                   ? std::string()
                   : "no file " + o.profile_file;
      });
  t.add("dds-peers", o.peers,
        "initial discovery peers, IPv4 addresses a,b,c: unicast discovery where multicast does not reach "
        "(README 'Across hosts')")
      .checkedBy([&o] {
        try {
          for (const auto& p : o.peers) parsePeerList(p);
          return std::string();
        } catch (const DdsError& e) {
          return std::string(e.what());
        }
      });
  t.add("dds-no-multicast", o.no_multicast,
        "no multicast discovery: only dds-peers (and this host) are asked");
  t.add("namespace", o.topic_namespace,
        "prefix of every topic (NS/densemap/scans ...): one map per namespace, several maps on one domain")
      .checkedBy([&o] { return checkTopicNamespace(o.topic_namespace); });
  t.add("dds-lease-s", o.lease_s,
        "participant lease in seconds (0: Fast DDS's 20 s): peers notice a crash this late; an outage longer "
        "than this drops the peer")
      .range(0.0, 3600.0);
  t.add(
       "security-dir", o.security_dir,
       "DDS-Security identity folder (tools/make-security.sh KEYSTORE, then KEYSTORE/<identity>; or an SROS2 "
       "enclave): authenticated, access-controlled and encrypted. Empty: plain DDS, unauthenticated")
      .checkedBy([&o] {
        return o.security_dir.empty() || std::filesystem::is_directory(o.security_dir)
                   ? std::string()
                   : "no folder " + o.security_dir + " (make one with tools/make-security.sh)";
      });
  return t;
}

}  // namespace densemap::msg
