#include "densemap/msg/topic_namespace.h"

#include <cctype>

namespace densemap::msg {

std::string checkTopicNamespace(const std::string& ns) {
  if (ns.empty()) return "";
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
