// Every topic name densemap makes is one any conforming DDS accepts (Cyclone DDS 0.10's rule: letters,
// digits, '_' and '/', not starting with a digit), and ids map to names one to one.
#include <cctype>
#include <set>
#include <string>

#include <gtest/gtest.h>

#include "densemap/msg/dds_node.h"
#include "densemap/msg/peer_topic.h"
#include "densemap/msg/topic_namespace.h"

namespace densemap::test {
namespace {

bool portableTopicName(const std::string& name) {
  if (name.empty() || std::isdigit(static_cast<unsigned char>(name.front()))) return false;
  for (char c : name)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '/') return false;
  return true;
}

TEST(TopicNames, IdsWithHyphensAndDotsMakePortableNames) {
  for (const std::string id : {"robot-0", "query-12345.3", "a.b-c_d", "7robot", "x", "R2_D2"}) {
    ASSERT_TRUE(msg::checkPeerId(id).empty()) << id;
    for (const char* base : {msg::kScanTopic, msg::kScanAckTopic, msg::kRobotProgressTopic,
                             msg::kQueryReplyTopic, msg::kAdminReplyTopic}) {
      const std::string topic = msg::peerTopicOf(base, id);
      EXPECT_TRUE(portableTopicName(topic)) << topic;
      EXPECT_EQ(msg::peerOfTopic(base, topic), id) << topic;
    }
  }
  EXPECT_EQ(msg::peerTopicOf(msg::kScanTopic, "robot-0"), "densemap/scans/robot_h0");
  EXPECT_EQ(msg::peerTopicOf(msg::kScanTopic, "robot_0"), "densemap/scans/robot__0");
  EXPECT_EQ(msg::peerTopicOf(msg::kQueryReplyTopic, "query-7.2"), "densemap/query/reply/query_h7_d2");
}

TEST(TopicNames, TheMappingIsOneToOne) {
  // Every id of up to three characters over the id alphabet's awkward corner: no two share a name.
  const std::string alphabet = "a0_-.";
  std::set<std::string> names;
  std::size_t ids = 0;
  for (std::size_t n = 1; n <= 3; ++n) {
    std::string id(n, 'a');
    std::size_t count = 1;
    for (std::size_t i = 0; i < n; ++i) count *= alphabet.size();
    for (std::size_t k = 0; k < count; ++k) {
      std::size_t rest = k;
      for (std::size_t i = 0; i < n; ++i, rest /= alphabet.size()) id[i] = alphabet[rest % alphabet.size()];
      if (!msg::checkPeerId(id).empty()) continue;
      ++ids;
      const std::string name = msg::peerNameOf(id);
      EXPECT_TRUE(names.insert(name).second) << id << " -> " << name << " collides";
      EXPECT_EQ(msg::peerIdOf(name), id);
    }
  }
  EXPECT_GT(ids, 50u);
}

TEST(TopicNames, NamesThatAreNoEscapeOfAnAcceptedIdNameNoPeer) {
  for (const std::string name : {"robot-0", "robot.0", "robot_", "robot_x", "_h", "", "a/b", "a b"})
    EXPECT_FALSE(msg::peerIdOf(name).has_value()) << "'" << name << "'";
  EXPECT_FALSE(msg::peerOfTopic(msg::kScanTopic, "densemap/scans/robot-0").has_value());
  EXPECT_TRUE(msg::isUnderPeerBase(msg::kScanTopic, "densemap/scans/robot-0"));
  EXPECT_FALSE(msg::isUnderPeerBase(msg::kScanTopic, "densemap/scans"));
}

TEST(TopicNames, IdsThatCannotBeMappedAreRefusedWithTheReason) {
  EXPECT_NE(msg::checkPeerId("").find("1 to 63"), std::string::npos);
  EXPECT_NE(msg::checkPeerId(std::string(64, 'a')).find("1 to 63"), std::string::npos);
  EXPECT_NE(msg::checkPeerId("-robot", "robot").find("must start with a letter or a digit"),
            std::string::npos);
  EXPECT_NE(msg::checkPeerId("robot*1", "robot").find("only letters"), std::string::npos);
  EXPECT_NE(msg::checkPeerId("robot/1", "robot").find("robot id 'robot/1'"), std::string::npos);
}

TEST(TopicNames, NamespacesKeepEveryNamePortable) {
  EXPECT_EQ(msg::checkTopicNamespace("fleet_a/site2"), "");
  EXPECT_NE(msg::checkTopicNamespace("2fleet").find("must not start with a digit"), std::string::npos);
  EXPECT_NE(msg::checkTopicNamespace("fleet-a").find("only letters"), std::string::npos);
  EXPECT_NE(msg::checkTopicNamespace("fleet//a").find("empty segment"), std::string::npos);
  for (const char* base : {msg::kScanTopic, msg::kQueryRequestTopic, msg::kStatisticsTopic})
    EXPECT_TRUE(portableTopicName(std::string("fleet_a/site2/") + base));
}

}  // namespace
}  // namespace densemap::test
