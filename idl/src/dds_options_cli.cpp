#include "densemap/msg/dds_options_cli.h"

#include <arpa/inet.h>

#include <sstream>

namespace densemap::msg {

std::vector<std::string> parsePeerList(const std::string& text) {
  std::vector<std::string> peers;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    if (item.empty()) continue;
    in_addr parsed{};
    if (inet_pton(AF_INET, item.c_str(), &parsed) != 1) {
      throw DdsError("DDS peer '" + item + "' is not an IPv4 address (give --dds-peers as a,b,c)");
    }
    peers.push_back(item);
  }
  return peers;
}

void addDdsOptions(CLI::App& app, DdsOptions& o) {
  app.add_option("--domain", o.domain, "DDS domain id (UDP ports 7400 + 250 * domain and up)")
      ->capture_default_str()
      ->check(CLI::Range(0, 232));
  app.add_flag("--loopback", o.loopback, "DDS on this host only (shared memory + UDP on 127.0.0.1)");
  app.add_flag("--udp-only", o.udp_only,
               "DDS over UDP only, no shared memory (between containers or hosts that share /dev/shm)");
  app.add_option("--dds-profile", o.profile_file, "Fast DDS XML profile file instead of the built-in one")
      ->check(CLI::ExistingFile);
  app.add_option("--dds-peers", o.peers,
                 "initial discovery peers, IPv4 addresses a,b,c: unicast discovery of the participants on "
                 "those hosts (where multicast is blocked; see README 'Across hosts')")
      ->delimiter(',')
      ->check([](const std::string& v) {
        try {
          parsePeerList(v);
          return std::string();
        } catch (const DdsError& e) {
          return std::string(e.what());
        }
      });
  app.add_flag("--dds-no-multicast", o.no_multicast,
               "no multicast discovery at all: only --dds-peers (and this host) are asked");
  app.add_option(
         "--dds-lease-s", o.lease_s,
         "participant lease in seconds (0: Fast DDS's 20 s): after a crash, peers notice it this late; "
         "a network outage longer than this drops the peer")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 3600.0));
}

}  // namespace densemap::msg
