// DDS discovery settings shared by every program: --dds-peers / --dds-no-multicast parse, are validated,
// and two participants configured that way find each other by unicast alone. Across network namespaces
// (multicast blocked on the links) the same settings are exercised by tests/load/cross_host.sh.
#include <algorithm>
#include <chrono>
#include <optional>
#include <thread>

#include <gtest/gtest.h>

#include "densemap/cli/option_cli.h"
#include "densemap/client/joining_client.h"
#include "densemap/client/query_client.h"
#include "densemap/client/scan_publisher.h"
#include "densemap/client/server_join.h"
#include "densemap/msg/dds_options_cli.h"
#include "service_harness.h"
#include "test_simulator.h"

using namespace densemap;

TEST(DdsOptions, PeerListsParseAndBadEntriesAreNamed) {
  EXPECT_EQ(msg::parsePeerList("10.0.0.1,192.168.1.20"),
            (std::vector<std::string>{"10.0.0.1", "192.168.1.20"}));
  EXPECT_TRUE(msg::parsePeerList("").empty());
  for (const char* bad : {"10.0.0", "server.local", "10.0.0.1:7400", "10.0.0.1,,x", "300.1.1.1"}) {
    try {
      msg::parsePeerList(bad);
      ADD_FAILURE() << bad << " was accepted";
    } catch (const msg::DdsError& e) {
      EXPECT_NE(std::string(e.what()).find("is not an IPv4 address"), std::string::npos) << e.what();
    }
  }
}

TEST(DdsOptions, FlagsFillTheOptionsAndRejectBadPeers) {
  CLI::App app;
  msg::DdsOptions o;
  auto table = msg::ddsOptions(o);
  cli::addToApp(app, {&table});
  std::vector<std::string> args{"--dds-no-multicast", "--dds-peers", "10.1.2.3,10.1.2.4",
                                "--domain",           "7",           "--udp-only"};
  std::reverse(args.begin(), args.end());
  app.parse(args);
  options::finishOptions({&table});
  EXPECT_EQ(o.domain, 7);
  EXPECT_TRUE(o.udp_only);
  EXPECT_TRUE(o.no_multicast);
  EXPECT_EQ(o.peers, (std::vector<std::string>{"10.1.2.3", "10.1.2.4"}));

  CLI::App bad;
  msg::DdsOptions ob;
  auto bad_table = msg::ddsOptions(ob);
  cli::addToApp(bad, {&bad_table});
  std::vector<std::string> wrong{"host-a", "--dds-peers"};
  bad.parse(wrong);
  try {
    options::finishOptions({&bad_table});
    ADD_FAILURE() << "a peer that is not an IPv4 address was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("--dds-peers"), std::string::npos) << e.what();
  }
}

// Without multicast, a robot given the server's address as its peer maps its scans and a query client
// with the same settings gets answers: unicast discovery alone is enough.
TEST(DdsOptions, UnicastPeersAloneDiscoverTheServer) {
  auto o = test::serverOptions(116);
  o.dds.loopback = false;
  o.dds.udp_only = true;
  o.dds.no_multicast = true;
  test::TestServer srv(o);
  msg::DdsOptions client_dds;
  client_dds.domain = 116;
  client_dds.udp_only = true;
  client_dds.no_multicast = true;
  client_dds.peers = {"127.0.0.1"};
  msg::DdsNode node(client_dds);
  client::ScanPublisher publisher(node, {"peer-robot"});
  ASSERT_TRUE(publisher.waitForServer(std::chrono::seconds(20))) << "no discovery through the peer list";
  io::LidarSimulator sim(test::smallSimulator(3, 16, 256));
  std::vector<io::Scan> scans;
  for (std::size_t i = 0; i < sim.size(); ++i) scans.push_back(sim.read(i));
  for (std::size_t i = 0; i < scans.size(); ++i) ASSERT_TRUE(publisher.publish("peer-robot", i, scans[i]));
  const auto acks = publisher.waitForAcks({"peer-robot"}, scans.size(), std::chrono::seconds(30));
  EXPECT_EQ(acks.applied, scans.size());
  client::QueryClient qc(node, "peer-client");
  ASSERT_TRUE(qc.waitForServer(std::chrono::seconds(20)));
  msg::QueryRequest rq;
  rq.kind(msg::QUERY_STATS);
  const auto r = qc.call(rq);
  EXPECT_EQ(r.status(), msg::STATUS_OK);
  EXPECT_EQ(r.stats().map_version(), scans.size());
  EXPECT_GT(r.stats().known_cells(), 0u);
}

/// DDS on this host only, on `domain`.
static msg::DdsOptions loopbackOn(int domain) {
  msg::DdsOptions dds;
  dds.domain = domain;
  dds.loopback = true;
  return dds;
}

// client::JoiningClient (densemap-query; densemap-replay's --rejoin-after does the same for its robots): a
// participant not matched within an attempt is replaced by a new one, and the wait goes on with it until
// the server comes. Here no server is up for the first attempts, so the participant is replaced; the last
// one joins and its scans are mapped.
TEST(ServerJoin, AParticipantNotMatchedIsReplacedAndTheNewOneJoins) {
  const int domain = 101;
  std::optional<test::TestServer> srv;  // outlives the robot
  client::JoiningClient<client::ScanPublisher, std::vector<std::string>> robot(
      loopbackOn(domain), std::vector<std::string>{"rejoining-robot"});
  std::thread late([&] {
    std::this_thread::sleep_for(std::chrono::seconds(5));
    srv.emplace(test::serverOptions(domain));
  });
  const auto j = robot.join(std::chrono::seconds(30), std::chrono::milliseconds(1500));
  late.join();
  ASSERT_TRUE(j.joined) << j.state;
  EXPECT_GE(j.rejoins, 2) << "the participant was not replaced while no server was up";
  EXPECT_EQ(robot.participants(), j.rejoins + 1);
  io::LidarSimulator sim(test::smallSimulator(2, 16, 256));
  client::ScanPublisher& publisher = robot.client();
  for (std::size_t i = 0; i < sim.size(); ++i)
    ASSERT_TRUE(publisher.publish("rejoining-robot", i, sim.read(i)));
  EXPECT_EQ(publisher.waitForAcks({"rejoining-robot"}, sim.size(), std::chrono::seconds(30)).applied,
            sim.size());
}

// Without a server at all the wait ends at its timeout, not matched, saying what is missing.
TEST(ServerJoin, NoServerEndsAtTheTimeoutWithTheMissingMatches) {
  msg::DdsNode node(loopbackOn(102));
  client::ScanPublisher publisher(node, {"lonely-robot"});
  int rejoins = 0;
  const auto j = client::joinServer([&]() -> client::ScanPublisher& { return publisher; }, [&] { ++rejoins; },
                                    std::chrono::milliseconds(1200), std::chrono::milliseconds(500));
  EXPECT_FALSE(j.joined);
  EXPECT_EQ(j.rejoins, rejoins);
  // Attempts of 500, 500 and the last 200 ms: a replacement after each full one (fewer when one overran).
  EXPECT_GE(j.rejoins, 1);
  EXPECT_LE(j.rejoins, 2);
  EXPECT_NE(j.state.find("lonely-robot: scans read by 0 server reader(s)"), std::string::npos) << j.state;
  EXPECT_NE(j.state.find("no statistics from a server yet"), std::string::npos) << j.state;
}

// A query client joins the same way (densemap-query, densemap-replay --robots 0), and says what it misses.
// Only a secure participant is ever replaced: a plain one has no handshake to stall.
TEST(ServerJoin, AQueryClientWithoutAServerSaysWhatIsMissing) {
  msg::DdsNode node(loopbackOn(103));
  client::QueryClient query(node, "lonely-client");
  int rejoins = 0;
  const auto j = client::joinServer([&]() -> client::QueryClient& { return query; }, [&] { ++rejoins; },
                                    std::chrono::milliseconds(700), std::chrono::milliseconds(300));
  EXPECT_FALSE(j.joined);
  EXPECT_EQ(j.rejoins, rejoins);
  EXPECT_GE(j.rejoins, 1);
  EXPECT_NE(
      j.state.find("lonely-client: requests read by 0 server reader(s), replies from 0 server writer(s)"),
      std::string::npos)
      << j.state;
  client::JoinOptions o;
  o.wait_s = 10;
  o.rejoin_after_s = 2;
  EXPECT_EQ(o.wait(), std::chrono::seconds(10));
  EXPECT_EQ(o.attempt(true), std::chrono::seconds(2));
  EXPECT_EQ(o.attempt(false), std::chrono::seconds(10));
  o.rejoin_after_s = 0;
  EXPECT_EQ(o.attempt(true), std::chrono::seconds(10));
}
