// No client waits in silence: densemap-replay and densemap-query, run as a user runs them, say within 2 s
// what they wait for, end a wait with no server with an error naming the likely causes, and map every scan
// when the server comes late.
#include <chrono>
#include <future>
#include <regex>
#include <thread>

#include <gtest/gtest.h>

#include "run_command.h"
#include "service_harness.h"

namespace densemap::test {
namespace {

using Clock = std::chrono::steady_clock;

std::string replay(int domain, const std::string& more) {
  return std::string(DENSEMAP_REPLAY_BINARY) + " --domain " + std::to_string(domain) +
         " --loopback --source sim:scans=3,beams=16,columns=256 --log-level info " + more;
}

/// Milliseconds of day of the first log line holding `text` ("[HH:MM:SS.mmm] ..."), or -1.
long logTimeMs(const std::string& log, const std::string& text) {
  const auto at = log.find(text);
  if (at == std::string::npos) return -1;
  const auto line = log.rfind('\n', at) == std::string::npos ? 0 : log.rfind('\n', at) + 1;
  std::smatch m;
  const std::string head = log.substr(line, 16);
  if (!std::regex_search(head, m, std::regex(R"(\[(\d\d):(\d\d):(\d\d)\.(\d\d\d)\])"))) return -1;
  return ((std::stol(m[1]) * 60 + std::stol(m[2])) * 60 + std::stol(m[3])) * 1000 + std::stol(m[4]);
}

void expectNoServerMessage(const CommandResult& r, int domain) {
  EXPECT_NE(r.exitCode(), 0) << r.output;
  EXPECT_NE(r.output.find("no densemap-server matched within 3 s"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("DDS domain " + std::to_string(domain)), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("densemap/scans/robot_h0"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("127.0.0.1 (--loopback)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("plain (no DDS-Security)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("Likely causes"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("another --domain"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("--loopback on one side only"), std::string::npos) << r.output;
}

TEST(ClientWaits, AReplayWithNoServerSaysWhatItWaitsForAndEndsWithTheLikelyCauses) {
  const auto t0 = Clock::now();
  const CommandResult r = runCommand(replay(51, "--wait 3"), Stderr::kCapture);
  const double took = std::chrono::duration<double>(Clock::now() - t0).count();
  expectNoServerMessage(r, 51);
  EXPECT_LT(took, 15.0) << "a 3 s wait took " << took << " s";
  // Said within 2 s of the wait starting (the source line comes just before it).
  const long source = logTimeMs(r.output, "] [info] source:");
  const long waiting = logTimeMs(r.output, "waiting up to 3 s for a densemap-server");
  EXPECT_NE(r.output.find("] [warning] waiting up to 3 s"), std::string::npos) << r.output;
  ASSERT_GE(source, 0) << r.output;
  ASSERT_GE(waiting, 0) << r.output;
  EXPECT_LE(waiting - source, 2000) << r.output;
}

TEST(ClientWaits, AReplayToAServerOnAnotherDomainEndsTheSameWay) {
  TestServer server(serverOptions(52));
  const CommandResult r = runCommand(replay(53, "--wait 3"), Stderr::kCapture);
  expectNoServerMessage(r, 53);
  EXPECT_EQ(server.service.statistics().totals().received, 0u);
}

TEST(ClientWaits, AReplayToAServerOnAnotherNamespaceSaysTheServersNamespace) {
  // The server announces itself and its namespace in its discovery data: the client names it.
  ServerOptions o = serverOptions(57);
  o.dds.topic_namespace = "fleet_a";
  TestServer server(o);
  const CommandResult r = runCommand(replay(57, "--wait 3"), Stderr::kCapture);
  expectNoServerMessage(r, 57);
  EXPECT_NE(r.output.find("1 densemap-server participant(s) are on this domain (namespace 'fleet_a')"),
            std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("this program uses another namespace"), std::string::npos) << r.output;
  EXPECT_EQ(server.service.statistics().totals().received, 0u);
}

TEST(ClientWaits, AQueryWithNoServerEndsWithTheLikelyCauses) {
  const CommandResult r = runCommand(
      std::string(DENSEMAP_QUERY_BINARY) + " --domain 54 --loopback --wait 3 stats", Stderr::kCapture);
  EXPECT_NE(r.exitCode(), 0) << r.output;
  EXPECT_NE(r.output.find("no densemap-server matched within 3 s"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("densemap/query/request"), std::string::npos) << r.output;
  // Said at its default log level (warnings) too, before the wait ends.
  EXPECT_NE(r.output.find("waiting up to 3 s for a densemap-server answering"), std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("Likely causes"), std::string::npos) << r.output;
}

TEST(ClientWaits, AReplayWhoseServerStartsFiveSecondsLateMapsEveryScan) {
  constexpr int kDomain = 55;
  auto run = std::async(std::launch::async,
                        [] { return runCommand(replay(kDomain, "--wait 60"), Stderr::kCapture); });
  std::this_thread::sleep_for(std::chrono::seconds(5));
  TestServer server(serverOptions(kDomain));
  const CommandResult r = run.get();
  EXPECT_EQ(r.exitCode(), 0) << r.output;
  EXPECT_NE(r.output.find("waiting up to 60 s for a densemap-server"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("matched the server after"), std::string::npos) << r.output;
  const auto until = Clock::now() + std::chrono::seconds(20);
  while (server.service.statistics().totals().processed < 3 && Clock::now() < until)
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  EXPECT_EQ(server.service.statistics().totals().processed, 3u);
}

}  // namespace
}  // namespace densemap::test
