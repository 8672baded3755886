// A topic per peer: replies go to densemap/query/reply/<client>, a robot's scans to densemap/scans/<robot>
// and its acknowledgements to densemap/scan_acks/<robot>. DDS-Security permissions grant topics by name, so
// a topic per peer lets each identity read only its own answers and publish only its own scans; and each
// peer receives only what is meant for it.
//
// Ids may hold '-' and '.', which no portable topic name may: the DDS specification leaves valid names
// undefined and Cyclone DDS 0.10 (Debian 12's, and the one ROS 2 Humble and Jazzy ship) refuses anything
// but letters, digits, '_' and '/'. So an id is written into a topic name through a one-to-one escape with
// '_' as the escape character: '_' -> "__", '-' -> "_h", '.' -> "_d" (robot-0 -> robot_h0, robot_0 ->
// robot__0: the two never meet). tools/make-security.sh applies the same mapping to its permissions.
#pragma once

#include <optional>
#include <string>

namespace densemap::msg {

/// Empty when `id` can name a peer (and its topic): 1..63 of letters, digits, '_', '.', '-', starting with a
/// letter or digit; else why not. `what` names the kind of id in the message ("client", "robot").
[[nodiscard]] std::string checkPeerId(const std::string& id, const char* what = "client");

/// The topic-name segment of an accepted id (letters, digits and '_' only; see above).
[[nodiscard]] std::string peerNameOf(const std::string& peer_id);

/// The id whose segment `name` is, when it is the escape of an accepted id; std::nullopt otherwise.
[[nodiscard]] std::optional<std::string> peerIdOf(const std::string& name);

/// `base_topic` + "/" + peerNameOf(`peer_id`).
[[nodiscard]] std::string peerTopicOf(const std::string& base_topic, const std::string& peer_id);

/// The peer whose topic `topic` is, when it is one under `base_topic` (both as on the wire).
[[nodiscard]] std::optional<std::string> peerOfTopic(const std::string& base_topic, const std::string& topic);

/// True when `topic` lies under `base_topic` + "/" (a peer topic, whether or not its segment decodes).
[[nodiscard]] bool isUnderPeerBase(const std::string& base_topic, const std::string& topic);

}  // namespace densemap::msg
