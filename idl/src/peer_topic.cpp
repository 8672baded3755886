#include "densemap/msg/peer_topic.h"

#include <cctype>

namespace densemap::msg {

namespace {
bool isAsciiAlnum(char c) { return std::isalnum(static_cast<unsigned char>(c)) != 0; }
}  // namespace

std::string checkPeerId(const std::string& id, const char* what) {
  const std::string name = std::string(what) + " id '" + id + "': ";
  if (id.empty() || id.size() > 63) return name + "1 to 63 characters";
  if (!isAsciiAlnum(id.front())) return name + "must start with a letter or a digit";
  for (char c : id) {
    if (!isAsciiAlnum(c) && c != '_' && c != '.' && c != '-')
      return name + "only letters, digits, '_', '.' and '-' are allowed";
  }
  return "";
}

std::string peerNameOf(const std::string& peer_id) {
  std::string out;
  out.reserve(peer_id.size() + 4);
  for (char c : peer_id) {
    switch (c) {
      case '_':
        out += "__";
        break;
      case '-':
        out += "_h";
        break;
      case '.':
        out += "_d";
        break;
      default:
        out += c;
    }
  }
  return out;
}

std::optional<std::string> peerIdOf(const std::string& name) {
  std::string id;
  for (std::size_t i = 0; i < name.size(); ++i) {
    const char c = name[i];
    if (c != '_') {
      if (!isAsciiAlnum(c)) return std::nullopt;
      id += c;
      continue;
    }
    if (++i == name.size()) return std::nullopt;  // a lone trailing escape
    switch (name[i]) {
      case '_':
        id += '_';
        break;
      case 'h':
        id += '-';
        break;
      case 'd':
        id += '.';
        break;
      default:
        return std::nullopt;
    }
  }
  if (!checkPeerId(id).empty()) return std::nullopt;
  return id;
}

std::string peerTopicOf(const std::string& base_topic, const std::string& peer_id) {
  return base_topic + "/" + peerNameOf(peer_id);
}

bool isUnderPeerBase(const std::string& base_topic, const std::string& topic) {
  return topic.size() > base_topic.size() + 1 && topic.compare(0, base_topic.size(), base_topic) == 0 &&
         topic[base_topic.size()] == '/';
}

std::optional<std::string> peerOfTopic(const std::string& base_topic, const std::string& topic) {
  if (!isUnderPeerBase(base_topic, topic)) return std::nullopt;
  return peerIdOf(topic.substr(base_topic.size() + 1));
}

}  // namespace densemap::msg
