// Which (robot, sequence number) pairs are in the journal: per robot a set of sequence intervals, so a
// robot that streams in order costs one interval however long it runs. It makes "applied at most once"
// hold across resends and restarts, and tells a reconnecting robot where to resume.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace densemap::server::durability {

class RobotProgress {
 public:
  /// Runs of the applied order kept per robot (older ones are forgotten; the set above is complete).
  static constexpr std::size_t kMaxOrderRuns = 4096;
  /// Records that a scan record of (robot, seq) is in the journal; false when the pair was there already.
  /// Every call counts in records(), so records() - count() is how many pairs the journal holds twice.
  bool record(const std::string& robot, std::uint64_t seq);
  bool contains(const std::string& robot, std::uint64_t seq) const;
  /// The highest recorded sequence number of the robot, if any.
  std::optional<std::uint64_t> lastSeq(const std::string& robot) const;
  /// How many distinct sequence numbers of the robot are recorded.
  std::uint64_t count(const std::string& robot) const;
  /// How many scan records of the robot were journaled (equal to count() unless a pair came twice).
  std::uint64_t records(const std::string& robot) const;
  std::size_t robots() const { return robots_.size(); }
  /// The order the robot's scans were journaled (and so applied) in, as runs of consecutive sequence
  /// numbers, the most recent `max`, oldest first: the map's lineage, from which an offline map in the same
  /// order is built (a resend after a restart lands after newer scans).
  std::vector<std::pair<std::uint64_t, std::uint64_t>> appliedOrder(const std::string& robot,
                                                                    std::size_t max) const;
  /// The robot's most recent `max` intervals (first, last), oldest first.
  std::vector<std::pair<std::uint64_t, std::uint64_t>> recentIntervals(const std::string& robot,
                                                                       std::size_t max) const;
  template <class F>
  void forEachRobot(F&& f) const {
    for (const auto& [id, r] : robots_)
      f(id, r.count, r.records, r.intervals.empty() ? 0 : r.intervals.rbegin()->second);
  }

  std::string encode() const;
  /// Throws util::FormatError (offsets counted from `base`).
  static RobotProgress decode(std::string_view bytes, std::size_t base = 0);
  bool operator==(const RobotProgress&) const = default;

 private:
  struct Robot {
    std::map<std::uint64_t, std::uint64_t> intervals;  ///< first -> last (inclusive), disjoint, not adjacent
    std::uint64_t count = 0;
    std::uint64_t records = 0;
    std::vector<std::pair<std::uint64_t, std::uint64_t>> order;  ///< runs in journal order (kMaxOrderRuns)
    bool operator==(const Robot&) const = default;
  };
  std::map<std::string, Robot> robots_;
};

}  // namespace densemap::server::durability
