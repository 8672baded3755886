#include "densemap/server/durability/robot_progress.h"

#include <algorithm>
#include <iterator>

#include "densemap/util/byte_codec.h"

namespace densemap::server::durability {

namespace {
template <class Robot>
void noteOrder(Robot& r, std::uint64_t seq) {
  if (!r.order.empty() && r.order.back().second + 1 == seq) {
    r.order.back().second = seq;
    return;
  }
  r.order.emplace_back(seq, seq);
  if (r.order.size() > RobotProgress::kMaxOrderRuns) r.order.erase(r.order.begin());
}
}  // namespace

bool RobotProgress::record(const std::string& robot, std::uint64_t seq) {
  Robot& r = robots_[robot];
  ++r.records;
  auto& iv = r.intervals;
  auto next = iv.upper_bound(seq);  // first interval starting after seq
  if (next != iv.begin()) {
    auto prev = std::prev(next);
    if (seq <= prev->second) return false;  // inside [prev.first, prev.second]
    if (prev->second + 1 == seq) {          // extends prev
      prev->second = seq;
      if (next != iv.end() && next->first == seq + 1) {  // and joins next
        prev->second = next->second;
        iv.erase(next);
      }
      ++r.count;
      noteOrder(r, seq);
      return true;
    }
  }
  if (next != iv.end() && next->first == seq + 1) {  // extends next downwards
    const std::uint64_t last = next->second;
    iv.erase(next);
    iv.emplace(seq, last);
  } else {
    iv.emplace(seq, seq);
  }
  ++r.count;
  noteOrder(r, seq);
  return true;
}

bool RobotProgress::contains(const std::string& robot, std::uint64_t seq) const {
  auto it = robots_.find(robot);
  if (it == robots_.end()) return false;
  auto next = it->second.intervals.upper_bound(seq);
  return next != it->second.intervals.begin() && seq <= std::prev(next)->second;
}

std::optional<std::uint64_t> RobotProgress::lastSeq(const std::string& robot) const {
  auto it = robots_.find(robot);
  if (it == robots_.end() || it->second.intervals.empty()) return std::nullopt;
  return it->second.intervals.rbegin()->second;
}

std::uint64_t RobotProgress::count(const std::string& robot) const {
  auto it = robots_.find(robot);
  return it == robots_.end() ? 0 : it->second.count;
}

std::vector<std::pair<std::uint64_t, std::uint64_t>> RobotProgress::recentIntervals(const std::string& robot,
                                                                                    std::size_t max) const {
  std::vector<std::pair<std::uint64_t, std::uint64_t>> out;
  auto it = robots_.find(robot);
  if (it == robots_.end()) return out;
  for (auto r = it->second.intervals.rbegin(); r != it->second.intervals.rend() && out.size() < max; ++r)
    out.emplace_back(r->first, r->second);
  std::reverse(out.begin(), out.end());
  return out;
}

std::vector<std::pair<std::uint64_t, std::uint64_t>> RobotProgress::appliedOrder(const std::string& robot,
                                                                                 std::size_t max) const {
  auto it = robots_.find(robot);
  if (it == robots_.end()) return {};
  const auto& o = it->second.order;
  const std::size_t n = std::min(max, o.size());
  return {o.end() - static_cast<std::ptrdiff_t>(n), o.end()};
}

std::uint64_t RobotProgress::records(const std::string& robot) const {
  auto it = robots_.find(robot);
  return it == robots_.end() ? 0 : it->second.records;
}

std::string RobotProgress::encode() const {
  std::string out;
  util::ByteWriter w(out);
  w.put(static_cast<std::uint64_t>(robots_.size()));
  for (const auto& [id, r] : robots_) {
    w.string(id);
    w.put(r.count);
    w.put(r.records);
    w.put(static_cast<std::uint64_t>(r.intervals.size()));
    for (const auto& [first, last] : r.intervals) {
      w.put(first);
      w.put(last);
    }
    w.put(static_cast<std::uint64_t>(r.order.size()));
    for (const auto& [first, last] : r.order) {
      w.put(first);
      w.put(last);
    }
  }
  return out;
}

RobotProgress RobotProgress::decode(std::string_view bytes, std::size_t base) {
  util::ByteReader r(bytes, base);
  RobotProgress p;
  const std::uint64_t robots = r.count("robot count", 4 + 24);
  for (std::uint64_t i = 0; i < robots; ++i) {
    std::string id = r.string("robot id", 4096);
    if (id.empty()) r.fail("an empty robot id");
    Robot robot;
    robot.count = r.get<std::uint64_t>("robot scan count");
    robot.records = r.get<std::uint64_t>("robot record count");
    if (robot.records < robot.count) r.fail("robot " + id + ": fewer records than scans");
    const std::uint64_t n = r.count("robot interval count", 16);
    std::uint64_t total = 0;
    bool first_interval = true;
    std::uint64_t prev_last = 0;
    for (std::uint64_t k = 0; k < n; ++k) {
      const auto first = r.get<std::uint64_t>("interval first");
      const auto last = r.get<std::uint64_t>("interval last");
      // Sorted, disjoint and not adjacent, as record() keeps them: anything else is damage.
      if (last < first || (!first_interval && first <= prev_last + 1))
        r.fail("robot " + id + ": bad interval");
      total += last - first + 1;
      robot.intervals.emplace(first, last);
      prev_last = last;
      first_interval = false;
    }
    if (total != robot.count) r.fail("robot " + id + ": its count does not match its intervals");
    const std::uint64_t runs = r.count("robot order runs", 16);
    if (runs > kMaxOrderRuns) r.fail("robot " + id + ": too many order runs");
    for (std::uint64_t k = 0; k < runs; ++k) {
      const auto first = r.get<std::uint64_t>("order first");
      const auto last = r.get<std::uint64_t>("order last");
      if (last < first) r.fail("robot " + id + ": bad order run");
      robot.order.emplace_back(first, last);
    }
    if (!p.robots_.emplace(std::move(id), std::move(robot)).second) r.fail("a robot twice");
  }
  if (!r.done()) r.fail("bytes after the robot progress");
  return p;
}

}  // namespace densemap::server::durability
