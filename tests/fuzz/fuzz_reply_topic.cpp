// libFuzzer target for the per-client reply topics (idl/src/reply_topic.cpp): a topic name from discovery
// (any remote reader's) names one of our clients or none; a client id is accepted only when it can name a
// topic, and a topic made from an accepted id reads back as that id.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "densemap/msg/reply_topic.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  const std::string base = "ns/densemap/query/reply";
  if (const auto id = densemap::msg::clientOfReplyTopic(base, text)) {
    if (!densemap::msg::checkClientId(*id).empty()) std::abort();
    if (densemap::msg::replyTopicOf(base, *id) != text) std::abort();
  }
  if (densemap::msg::checkClientId(text).empty()) {
    const auto back = densemap::msg::clientOfReplyTopic(base, densemap::msg::replyTopicOf(base, text));
    if (!back || *back != text) std::abort();
    if (text.find('/') != std::string::npos) std::abort();
  }
  return 0;
}
