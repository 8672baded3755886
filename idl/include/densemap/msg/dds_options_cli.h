// The DDS options, declared once for every densemap program (server, replay, query).
#pragma once

#include "densemap/msg/dds_node.h"
#include "densemap/msg/peer_list.h"
#include "densemap/options/option_table.h"

namespace densemap::msg {

/// --domain, --loopback, --udp-only, --dds-profile, --dds-peers, --dds-no-multicast, --dds-lease-s.
options::OptionTable ddsOptions(DdsOptions& options);

}  // namespace densemap::msg
