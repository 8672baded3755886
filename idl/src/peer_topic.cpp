#include "densemap/msg/peer_topic.h"

#include <cctype>

namespace densemap::msg {

std::string checkPeerId(const std::string& id, const char* what) {
  const std::string name = std::string(what) + " id '" + id + "': ";
  if (id.empty() || id.size() > 63) return name + "1 to 63 characters";
  if (!std::isalnum(static_cast<unsigned char>(id.front())))
    return name + "must start with a letter or a digit";
  for (char c : id) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '.' && c != '-')
      return name + "only letters, digits, '_', '.' and '-' are allowed";
  }
  return "";
}

std::string peerTopicOf(const std::string& base_topic, const std::string& peer_id) {
  return base_topic + "/" + peer_id;
}

std::optional<std::string> peerOfTopic(const std::string& base_topic, const std::string& topic) {
  if (topic.size() <= base_topic.size() + 1 || topic.compare(0, base_topic.size(), base_topic) != 0 ||
      topic[base_topic.size()] != '/')
    return std::nullopt;
  std::string id = topic.substr(base_topic.size() + 1);
  if (!checkPeerId(id).empty()) return std::nullopt;
  return id;
}

}  // namespace densemap::msg
