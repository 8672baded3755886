// One map per namespace: a second server on the same topics is seen by both and refuses to
// serve; --namespace keeps independent maps apart on one domain; replies and acknowledgements say which
// server sent them.
#include <gtest/gtest.h>

#include "service_harness.h"

namespace densemap::test {
namespace {

ServerOptions namedServer(int domain, const std::string& id, const std::string& ns, double check_s) {
  auto o = serverOptions(domain);
  o.server_id = id;
  o.dds.topic_namespace = ns;
  o.duplicate_check_s = check_s;
  o.map_dir = testMapDir(domain) + "-" + id;
  return o;
}

msg::DdsOptions clientDds(int domain, const std::string& ns) {
  msg::DdsOptions d;
  d.domain = domain;
  d.loopback = true;
  d.topic_namespace = ns;
  d.name = "test-client";
  return d;
}

TEST(Namespaces, ASecondServerOnTheSameTopicsIsSeenByBothAndRefused) {
  TestServer first(namedServer(142, "server-a", "", 0.0));
  try {
    TestServer second(namedServer(142, "server-b", "", 2.0));
    ADD_FAILURE() << "a second server on the same topics started serving";
  } catch (const server::dds_edge::AnotherServerError& e) {
    EXPECT_NE(std::string(e.what()).find("server-a"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("--namespace"), std::string::npos) << e.what();
  }
  EXPECT_EQ(first.edge.otherServersSeen(), 1u) << "the running server did not notice the second one";
  EXPECT_FALSE(first.edge.refused()) << "the server that started first keeps serving";
  // And it still serves.
  msg::DdsNode node(clientDds(142, ""));
  client::QueryClient query(node, "after");
  ASSERT_TRUE(query.waitForServer(20s));
  msg::QueryRequest rq;
  rq.kind(msg::QUERY_STATS);
  EXPECT_EQ(query.call(rq, 10s).server_id(), "server-a");
}

TEST(Namespaces, NamespacesKeepIndependentMapsApartOnOneDomain) {
  TestServer a(namedServer(143, "server-a", "fleet_a", 1.0));
  TestServer b(namedServer(143, "server-b", "fleet_b", 1.0));
  EXPECT_EQ(a.edge.otherServersSeen(), 0u);
  EXPECT_EQ(b.edge.otherServersSeen(), 0u);
  msg::DdsNode node_a(clientDds(143, "fleet_a")), node_b(clientDds(143, "fleet_b"));
  client::ScanPublisher robot(node_a, {"robot-0"});
  client::QueryClient query_a(node_a, "qa"), query_b(node_b, "qb");
  ASSERT_TRUE(robot.waitForServer(20s));
  ASSERT_TRUE(query_a.waitForServer(20s));
  ASSERT_TRUE(query_b.waitForServer(20s));
  const auto scans = simScans(2);
  for (std::size_t i = 0; i < scans.size(); ++i) ASSERT_TRUE(robot.publish("robot-0", i, scans[i]));
  ASSERT_EQ(robot.waitForAcks({"robot-0"}, 2, 60s).applied, 2u);
  EXPECT_EQ(robot.ack("robot-0", 1)->server_id(), "server-a");
  msg::QueryRequest stats;
  stats.kind(msg::QUERY_STATS);
  const auto ra = query_a.call(stats, 10s), rb = query_b.call(stats, 10s);
  EXPECT_EQ(ra.server_id(), "server-a");
  EXPECT_EQ(rb.server_id(), "server-b");
  EXPECT_EQ(ra.stats().map_version(), 2u);
  EXPECT_EQ(rb.stats().map_version(), 0u) << "fleet_b's map got fleet_a's scans";
  EXPECT_EQ(b.service.statistics().totals().received, 0u);
}

TEST(Namespaces, AnInvalidNamespaceIsAnError) {
  for (const std::string bad : {"a//b", "/a", "a/", "a b", "a-b"}) {
    EXPECT_THROW(msg::DdsNode(clientDds(144, bad)), msg::DdsError) << bad;
  }
}

}  // namespace
}  // namespace densemap::test
