#include "densemap/msg/topic_namespace.h"

#include <cctype>

namespace densemap::msg {

std::string checkTopicNamespace(const std::string& ns) {
  if (ns.empty()) return "";
  // Cyclone DDS 0.10 refuses a topic name that starts with a digit, and the namespace starts every name.
  if (std::isdigit(static_cast<unsigned char>(ns.front())))
    return "namespace '" + ns + "': must not start with a digit (portable DDS topic names do not)";
  bool segment_start = true;
  for (char c : ns) {
    if (c == '/') {
      if (segment_start) break;
      segment_start = true;
      continue;
    }
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_')
      return "namespace '" + ns + "': only letters, digits, '_' and '/' between segments are allowed";
    segment_start = false;
  }
  if (segment_start) return "namespace '" + ns + "': empty segment (leading, trailing or double '/')";
  return "";
}

}  // namespace densemap::msg
