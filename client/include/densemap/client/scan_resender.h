// A robot's side of "nothing acknowledged is lost": it remembers what it sent until the server's
// acknowledgement says the scan is in the map (durable, or given up: rejected, dropped). When the server
// restarts (its progress message comes from a new incarnation), every scan the server does not hold
// (after the robot's last durable sequence number there) is published again; the server applies a
// (robot, seq) pair at most once, so a resend never counts twice.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <string>

#include "densemap/client/scan_publisher.h"

namespace densemap::client {

struct ResendCounts {
  std::uint64_t restarts_seen = 0;  ///< server incarnations after the first
  std::uint64_t resent = 0;         ///< scans published again
  std::uint64_t held = 0;           ///< unacknowledged scans the restarted server had on disk already
  std::uint64_t skipped = 0;        ///< at the start: scans the server had on disk already (not sent)
};

class ScanResender {
 public:
  using ScanOf = std::function<io::Scan(std::uint64_t seq)>;
  /// `resend_after`: a scan still unacknowledged this long after it was sent is sent again (covers a
  /// resend the restarted server's reader missed while it was still matching); each further resend of
  /// the same scan waits twice as long (up to 16x), so a server that is slow to catch up is not flooded
  /// with copies of what it has queued already.
  ScanResender(ScanPublisher& publisher, std::string robot_id, ScanOf scan_of,
               std::chrono::milliseconds resend_after = std::chrono::seconds(5));

  /// The first sequence number to send at or after `first`: the server's progress (waited for up to
  /// `timeout`) says which ones it has already. Without a journal on the server: `first`.
  std::uint64_t resumeFrom(std::uint64_t first, std::uint64_t end, std::chrono::milliseconds timeout);
  /// Publishes one scan, retrying (and resending after a restart) while DDS refuses it, until `deadline`.
  /// False when it could not be published by then.
  bool send(std::uint64_t seq, std::chrono::steady_clock::time_point deadline);
  /// Forgets what was acknowledged; after a server restart, resends what the server does not hold.
  void poll();
  /// Polls until every sent scan is acknowledged or held by the server, or the deadline passes.
  bool settle(std::chrono::steady_clock::time_point deadline);
  std::size_t outstanding() const { return unacked_.size(); }
  const ResendCounts& counts() const { return counts_; }

 private:
  ScanPublisher& publisher_;
  std::string robot_id_;
  ScanOf scan_of_;
  void publishAgain(std::uint64_t seq, bool timed);
  std::chrono::milliseconds resend_after_;
  struct Unacked {
    std::chrono::steady_clock::time_point sent;
    int resends = 0;  ///< timed resends since the last restart (the backoff)
  };
  std::map<std::uint64_t, Unacked> unacked_;
  std::optional<std::uint64_t> incarnation_;
  ResendCounts counts_;
};

}  // namespace densemap::client
