// Topic namespaces (--namespace): one map per namespace, several on one domain.
#pragma once

#include <string>

namespace densemap::msg {

/// Empty when `ns` is a valid topic namespace (segments of letters, digits and '_' joined by '/', not
/// starting with a digit: every name must be one any conforming DDS accepts); else why not.
[[nodiscard]] std::string checkTopicNamespace(const std::string& ns);

}  // namespace densemap::msg
