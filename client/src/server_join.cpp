#include "densemap/client/server_join.h"

#include <algorithm>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <spdlog/spdlog.h>

namespace densemap::client {

namespace {
using JoinClock = std::chrono::steady_clock;
/// The first word within 2 s of starting to wait, then one line every 10 s.
constexpr std::chrono::milliseconds kFirstReport{1000}, kReportEvery{10000};

double secondsOf(JoinClock::duration d) { return std::chrono::duration<double>(d).count(); }
}  // namespace

namespace {
// What this process saw of the domain, for the messages of a join that found no server.
std::string whatWasSeen(const JoinContext& context) {
  const msg::DomainPresence seen = msg::domainPresenceInProcess();
  std::string out;
  if (seen.authentication_failures > 0) {
    out += fmt::format(
        " Authentication failed with {} participant(s) on this domain: is this identity signed by the "
        "server's CA, and is neither certificate expired or revoked?",
        seen.authentication_failures);
  }
  if (seen.servers_seen == 0) return out;
  const auto& ns = seen.server_namespaces;
  const bool same_namespace = std::find(ns.begin(), ns.end(), context.topic_namespace) != ns.end();
  std::vector<std::string> quoted;
  for (const std::string& n : ns) quoted.push_back(n.empty() ? "none" : "'" + n + "'");
  out +=
      fmt::format(" {} densemap-server participant(s) are on this domain (namespace {}) and matched nothing",
                  seen.servers_seen, fmt::join(quoted, ", "));
  if (!same_namespace) {
    out += ": this program uses another namespace (give the server's --namespace).";
  } else if (context.secure) {
    out +=
        ": the server did not admit this identity (its log names each refused participant: another CA, "
        "expired, revoked, or permissions that do not grant these topics).";
  } else {
    out +=
        ": are both of one densemap version (the wire types' names carry their version, so a server "
        "and a client of other versions never match)?";
  }
  return out;
}
}  // namespace

JoinContext joinContext(const msg::DdsOptions& dds, const msg::DdsNode& node, std::string what) {
  JoinContext c;
  c.what = std::move(what);
  c.secure = node.secure();
  c.topic_namespace = dds.topic_namespace;
  c.where =
      fmt::format("DDS domain {}, {}, {}, {}", dds.domain,
                  dds.topic_namespace.empty() ? "no namespace" : "namespace '" + dds.topic_namespace + "'",
                  msg::describeTransport(dds),
                  c.secure ? "secure as '" + node.identity().name + "'" : "plain (no DDS-Security)");
  return c;
}

std::string noServerMessage(const JoinContext& context, std::chrono::milliseconds waited,
                            const std::string& state) {
  std::string causes =
      "the server is not running yet or runs on another --domain; --loopback on one side only (it keeps DDS "
      "on 127.0.0.1 and shared memory, where the other side is on the network); another --namespace; "
      "multicast blocked between hosts (give --dds-peers); two independent servers on one namespace (each "
      "refuses to serve: see their logs)";
  causes +=
      context.secure
          ? "; the server refused this identity (another CA, expired or revoked: the server's log names "
            "each refused participant) or this identity's role may not use these topics"
          : "; the server is secure and this program is not (give --security-dir)";
  return fmt::format(
      "no densemap-server matched within {:g} s: waited for {} on {} ({}).{} Likely causes: {}",
      std::chrono::duration<double>(waited).count(), context.what, context.where, state, whatWasSeen(context),
      causes);
}

ServerJoin joinServerWith(const std::function<JoinTarget()>& target, const std::function<void()>& rejoin,
                          std::chrono::milliseconds timeout, std::chrono::milliseconds attempt,
                          const JoinContext* context) {
  const auto start = JoinClock::now();
  const auto give_up = start + timeout;
  auto next_report = start + kFirstReport;
  auto attempt_ends = start + attempt;
  ServerJoin out;
  JoinTarget t = target();
  for (;;) {
    const auto now = JoinClock::now();
    const auto until = std::min({give_up, attempt_ends, context ? next_report : give_up});
    if (t.wait_for_server(std::max(std::chrono::milliseconds(0),
                                   std::chrono::duration_cast<std::chrono::milliseconds>(until - now)))) {
      out.joined = true;
      if (context && JoinClock::now() > start + kFirstReport)
        spdlog::info("matched the server after {:.1f} s", secondsOf(JoinClock::now() - start));
      return out;
    }
    out.state = t.state();
    if (JoinClock::now() >= give_up) return out;
    if (context && JoinClock::now() >= next_report) {
      // Warnings, so a tool that logs only warnings by default (densemap-query) says it too.
      if (next_report == start + kFirstReport) {
        spdlog::warn("waiting up to {:g} s for {} on {}", secondsOf(timeout), context->what, context->where);
      } else {
        spdlog::warn("still waiting for the server ({:.0f} s of {:g} s): {}.{}",
                     secondsOf(JoinClock::now() - start), secondsOf(timeout), out.state,
                     whatWasSeen(*context));
      }
      next_report = JoinClock::now() + kReportEvery;
    }
    if (JoinClock::now() >= attempt_ends) {
      spdlog::warn(
          "the server has not matched this participant within {:.1f} s ({}): joining again with a new one",
          secondsOf(attempt), out.state);
      rejoin();
      ++out.rejoins;
      t = target();
      attempt_ends = JoinClock::now() + attempt;
    }
  }
}

std::chrono::milliseconds JoinOptions::wait() const {
  return std::chrono::milliseconds(static_cast<long>(wait_s * 1000));
}

std::chrono::milliseconds JoinOptions::attempt(bool secure) const {
  if (!secure || rejoin_after_s <= 0) return wait();
  return std::chrono::milliseconds(static_cast<long>(rejoin_after_s * 1000));
}

options::OptionTable joinOptions(JoinOptions& o) {
  options::OptionTable t("Joining the server");
  t.add("wait", o.wait_s,
        "seconds to wait for a server to match this program before giving up with the likely causes (what is "
        "awaited is logged after 1 s and every 10 s); robots also wait this long at the end for the last "
        "acknowledgements")
      .range(0.0, 86400.0);
  t.add("rejoin-after", o.rejoin_after_s,
        "secure mode: a participant the server has not matched within this many seconds is replaced by a new "
        "one, until --wait runs out (Fast DDS 2.9's secure discovery now and then never matches one "
        "participant; a new one authenticates afresh); 0: never")
      .range(0.0, 3600.0);
  return t;
}

}  // namespace densemap::client
