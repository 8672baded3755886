#include "densemap/client/scan_resender.h"

#include <thread>

#include <spdlog/spdlog.h>

namespace densemap::client {

ScanResender::ScanResender(ScanPublisher& publisher, std::string robot_id, ScanOf scan_of,
                           std::chrono::milliseconds resend_after)
    : publisher_(publisher),
      robot_id_(std::move(robot_id)),
      scan_of_(std::move(scan_of)),
      resend_after_(resend_after) {}

void ScanResender::publishAgain(std::uint64_t seq, bool timed) {
  publisher_.publish(robot_id_, seq, scan_of_(seq));  // a refused one is tried again later
  Unacked& u = unacked_[seq];
  u.sent = std::chrono::steady_clock::now();
  u.resends = timed ? u.resends + 1 : 0;
  ++counts_.resent;
}

std::uint64_t ScanResender::resumeFrom(std::uint64_t first, std::uint64_t end,
                                       std::chrono::milliseconds timeout) {
  const auto p = publisher_.waitForProgress(robot_id_, timeout);
  if (!p) {
    spdlog::warn(
        "{}: no robot progress from the server within {} ms: numbering starts at {} (a server "
        "that has these scans already answers them as duplicates)",
        robot_id_, timeout.count(), first);
    return first;
  }
  incarnation_ = p->incarnation();
  if (!p->journal()) return first;
  const auto last = lastDurableSeq(*p, robot_id_);
  if (!last || *last < first) return first;
  const std::uint64_t from = std::min(end, *last + 1);
  counts_.skipped += from - first;
  spdlog::info("{}: the server holds its scans up to {}: numbering goes on at {}", robot_id_, *last, from);
  return from;
}

bool ScanResender::send(std::uint64_t seq, std::chrono::steady_clock::time_point deadline) {
  unacked_[seq] = Unacked{std::chrono::steady_clock::now(), 0};
  const io::Scan scan = scan_of_(seq);
  while (!publisher_.publish(robot_id_, seq, scan)) {
    // Refused: the writer's history is full of scans for a server that is gone (until its lease ends).
    poll();
    if (std::chrono::steady_clock::now() >= deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  poll();
  return true;
}

void ScanResender::poll() {
  for (auto it = unacked_.begin(); it != unacked_.end();) {
    const auto a = publisher_.ack(robot_id_, it->first);
    // Durable, or given up by the server (dropped, rejected: resending would not change that).
    const bool final =
        a && (a->durable() || a->outcome() == msg::SCAN_DROPPED || (a->outcome() == msg::SCAN_REJECTED) ||
              (a->outcome() == msg::SCAN_APPLIED && !a->durable()));
    it = final ? unacked_.erase(it) : std::next(it);
  }
  // The server's progress is what it holds: a scan in it is durable even if its acknowledgement was lost
  // (acknowledgements written before the server's ack writer matched this robot never arrive).
  const auto p = publisher_.progress(robot_id_);
  if (p) {
    for (auto it = unacked_.begin(); it != unacked_.end();) {
      if (heldDurably(*p, robot_id_, it->first)) {
        ++counts_.held;
        it = unacked_.erase(it);
      } else {
        ++it;
      }
    }
  }
  const auto now = std::chrono::steady_clock::now();
  for (auto& [seq, u] : unacked_) {
    if (now - u.sent >= resend_after_ * (1 << std::min(u.resends, 4))) publishAgain(seq, true);
  }
  if (!p || (incarnation_ && p->incarnation() == *incarnation_)) return;
  const bool first_seen = !incarnation_.has_value();
  incarnation_ = p->incarnation();
  if (first_seen) return;
  ++counts_.restarts_seen;
  const auto last = lastDurableSeq(*p, robot_id_);
  std::size_t resent = 0, held = 0;
  for (auto it = unacked_.begin(); it != unacked_.end();) {
    if (heldDurably(*p, robot_id_, it->first)) {  // on the server's disk: its acknowledgement was lost
      ++held;
      it = unacked_.erase(it);
      continue;
    }
    publishAgain((it++)->first, false);
    ++resent;
  }
  counts_.held += held;
  spdlog::warn(
      "{}: the server restarted ('{}'): it holds scans up to {}; {} unacknowledged ones were on its disk, "
      "{} sent again",
      robot_id_, p->server_id(), last ? std::to_string(*last) : std::string("none"), held, resent);
}

bool ScanResender::settle(std::chrono::steady_clock::time_point deadline) {
  for (;;) {
    poll();
    if (unacked_.empty()) return true;
    if (std::chrono::steady_clock::now() >= deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
}

}  // namespace densemap::client
