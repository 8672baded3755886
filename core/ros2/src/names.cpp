#include "densemap/ros2/names.h"

#include <cctype>
#include <stdexcept>

namespace densemap::ros2 {

namespace {

void checkTokens(const std::string& name) {
  // rcl: tokens of [A-Za-z0-9_], not starting with a digit, separated by single '/'.
  if (name.size() < 2 || name.front() != '/' || name.back() == '/')
    throw std::invalid_argument("ROS 2 name '" + name + "' is not valid");
  bool token_start = true;
  for (std::size_t i = 1; i < name.size(); ++i) {
    const char c = name[i];
    if (c == '/') {
      if (token_start) throw std::invalid_argument("ROS 2 name '" + name + "' has an empty token");
      token_start = true;
      continue;
    }
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_') ||
        (token_start && std::isdigit(static_cast<unsigned char>(c))))
      throw std::invalid_argument("ROS 2 name '" + name + "' has a character ROS 2 does not allow ('" + c +
                                  "')");
    token_start = false;
  }
}

std::string splitType(const std::string& ros_type, const char* kind, std::string& package) {
  const auto first = ros_type.find('/');
  const auto second = ros_type.find('/', first + 1);
  if (first == std::string::npos || second == std::string::npos ||
      ros_type.substr(first + 1, second - first - 1) != kind)
    throw std::invalid_argument("ROS 2 type '" + ros_type + "' is not <package>/" + kind + "/<Type>");
  package = ros_type.substr(0, first);
  return ros_type.substr(second + 1);
}

}  // namespace

std::string resolveName(const std::string& name, const std::string& node_name,
                        const std::string& node_namespace) {
  std::string ns = node_namespace.empty() ? "/" : node_namespace;
  if (ns.back() != '/') ns += '/';
  std::string full;
  if (name.rfind("~/", 0) == 0 || name == "~")
    full = ns + node_name + (name.size() > 1 ? name.substr(1) : "");
  else if (!name.empty() && name.front() == '/')
    full = name;
  else
    full = ns + name;
  checkTokens(full);
  return full;
}

std::string topicOnDds(const std::string& t) { return "rt" + t; }
std::string requestTopicOnDds(const std::string& s) { return "rq" + s + "Request"; }
std::string replyTopicOnDds(const std::string& s) { return "rr" + s + "Reply"; }

std::string typeOnDds(const std::string& ros_type) {
  std::string package;
  const std::string type = splitType(ros_type, "msg", package);
  return package + "::msg::dds_::" + type + "_";
}

std::string requestTypeOnDds(const std::string& service_type) {
  std::string package;
  const std::string type = splitType(service_type, "srv", package);
  return package + "::srv::dds_::" + type + "_Request_";
}

std::string responseTypeOnDds(const std::string& service_type) {
  std::string package;
  const std::string type = splitType(service_type, "srv", package);
  return package + "::srv::dds_::" + type + "_Response_";
}

}  // namespace densemap::ros2
