// Replies go to a topic per client (densemap/query/reply/<client_id>), so DDS-Security permissions can let
// each client read its own answers and no one else's (issue 21), and a client receives only its replies.
#pragma once

#include <optional>
#include <string>

namespace densemap::msg {

/// Empty when `id` can name a client (and its reply topic): 1..63 of letters, digits, '_', '.', '-', starting
/// with a letter or digit; else why not.
std::string checkClientId(const std::string& id);

/// `reply_topic` + "/" + `client_id`.
std::string replyTopicOf(const std::string& reply_topic, const std::string& client_id);

/// The client whose reply topic `topic` is, when it is one under `reply_topic` (both as on the wire).
std::optional<std::string> clientOfReplyTopic(const std::string& reply_topic, const std::string& topic);

}  // namespace densemap::msg
