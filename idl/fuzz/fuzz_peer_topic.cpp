// libFuzzer target for the per-peer topics (idl/src/peer_topic.cpp): a topic name from discovery
// (any remote reader's or writer's) names one of our peers or none; an id is accepted only when it can name a
// topic, a topic made from an accepted id reads back as that id, and its segment is a portable name.
#include <cctype>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "densemap/msg/peer_topic.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  const std::string base = "ns/densemap/query/reply";
  if (const auto id = densemap::msg::peerOfTopic(base, text)) {
    if (!densemap::msg::checkPeerId(*id).empty()) std::abort();
    if (densemap::msg::peerTopicOf(base, *id) != text) std::abort();
  }
  if (densemap::msg::checkPeerId(text).empty()) {
    const auto back = densemap::msg::peerOfTopic(base, densemap::msg::peerTopicOf(base, text));
    if (!back || *back != text) std::abort();
    // The segment is a portable name: letters, digits and '_' only.
    for (char c : densemap::msg::peerNameOf(text))
      if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_') std::abort();
  }
  return 0;
}
