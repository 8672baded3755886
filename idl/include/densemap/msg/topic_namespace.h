// Topic namespaces (--namespace): one map per namespace, several on one domain.
#pragma once

#include <string>

namespace densemap::msg {

/// Empty when `ns` is a valid topic namespace (segments of letters, digits and '_' joined by '/'); else why
/// not.
std::string checkTopicNamespace(const std::string& ns);

}  // namespace densemap::msg
