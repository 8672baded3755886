#include "densemap/msg/peer_list.h"

#include <arpa/inet.h>

#include <sstream>

#include "densemap/msg/dds_node.h"

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

}  // namespace densemap::msg
