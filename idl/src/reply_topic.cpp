#include "densemap/msg/reply_topic.h"

#include <cctype>

namespace densemap::msg {

std::string checkClientId(const std::string& id) {
  if (id.empty() || id.size() > 63) return "client id '" + id + "': 1 to 63 characters";
  if (!std::isalnum(static_cast<unsigned char>(id.front())))
    return "client id '" + id + "': must start with a letter or a digit";
  for (char c : id) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '.' && c != '-')
      return "client id '" + id + "': only letters, digits, '_', '.' and '-' are allowed";
  }
  return "";
}

std::string replyTopicOf(const std::string& reply_topic, const std::string& client_id) {
  return reply_topic + "/" + client_id;
}

std::optional<std::string> clientOfReplyTopic(const std::string& reply_topic, const std::string& topic) {
  if (topic.size() <= reply_topic.size() + 1 || topic.compare(0, reply_topic.size(), reply_topic) != 0 ||
      topic[reply_topic.size()] != '/')
    return std::nullopt;
  std::string id = topic.substr(reply_topic.size() + 1);
  if (!checkClientId(id).empty()) return std::nullopt;
  return id;
}

}  // namespace densemap::msg
