// The DDS command-line options, declared once for every densemap program (server, replay, query).
#pragma once

#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "densemap/msg/dds_node.h"

namespace densemap::msg {

/// Adds --domain, --loopback, --udp-only, --dds-profile, --dds-peers and --dds-no-multicast to `app`
/// (and so to its --config file keys), writing into `options`.
void addDdsOptions(CLI::App& app, DdsOptions& options);

/// Parses "10.0.0.1,10.0.0.2" into addresses; throws DdsError naming the entry that is not an IPv4 address.
std::vector<std::string> parsePeerList(const std::string& text);

}  // namespace densemap::msg
