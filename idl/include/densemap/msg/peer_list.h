// --dds-peers: a comma-separated list of IPv4 addresses (the only parser of it).
#pragma once

#include <string>
#include <vector>

namespace densemap::msg {

/// Parses "10.0.0.1,10.0.0.2" into addresses; throws DdsError naming the entry that is not an IPv4 address.
std::vector<std::string> parsePeerList(const std::string& text);

}  // namespace densemap::msg
