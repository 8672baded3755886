// libFuzzer target for the --dds-peers parser: any text either parses into IPv4 addresses that round-trip
// through inet_pton, or is refused with DdsError; nothing else may happen.
#include <arpa/inet.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "densemap/msg/dds_node.h"
#include "densemap/msg/peer_list.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    for (const auto& peer : densemap::msg::parsePeerList(text)) {
      in_addr parsed{};
      if (peer.empty() || peer.find(',') != std::string::npos ||
          inet_pton(AF_INET, peer.c_str(), &parsed) != 1) {
        std::abort();  // accepted something that is not one IPv4 address
      }
    }
  } catch (const densemap::msg::DdsError&) {
    // refused with a message: fine
  }
  return 0;
}
