#include "densemap/update/method_chooser.h"

#include <algorithm>
#include <vector>

#include <spdlog/spdlog.h>

namespace densemap::update {

namespace {
// The order of first tries: the methods without generation cost first, so a short run (a benchmark of
// ten scans) spends its exploration where it is cheap.
constexpr UpdateMethod kTryOrder[] = {UpdateMethod::kBaseline, UpdateMethod::kCullingRegion,
                                      UpdateMethod::kSuperRaysCulling, UpdateMethod::kSuperRays};
bool cheap(UpdateMethod m) { return m == UpdateMethod::kBaseline || m == UpdateMethod::kCullingRegion; }
}  // namespace

UpdateMethod MethodChooser::best() const {
  UpdateMethod b = UpdateMethod::kBaseline;
  double cost = -1.0;
  for (UpdateMethod m : kTryOrder) {
    const Slot& s = slot(m);
    if (s.scans == 0) continue;
    if (cost < 0.0 || s.us_per_point < cost) cost = s.us_per_point, b = m;
  }
  return b;
}

UpdateMethod MethodChooser::next() {
  if (!started_) {
    for (UpdateMethod m : kTryOrder) {
      Slot& s = slot(m);
      s.interval = options_.probe_interval;
      s.due = cheap(m) ? 0 : options_.probe_after;
    }
    started_ = true;
  }
  const std::uint64_t now = scan_++;
  // Every method once, cheap ones first, then the cheap ones a second time (their first scan is the cold
  // one: with a single sample the choice between two methods within a few percent settled on noise until
  // the first re-try, 20 scans on); then the most overdue loser, if any is due; else the fastest. Other
  // than the cheap methods' first two tries, a try waits until the budget holds its expected cost.
  for (UpdateMethod m : kTryOrder)
    if (slot(m).scans == 0 && slot(m).due <= now && (cheap(m) || expectedExtraMs(m) <= budget_ms_)) return m;
  for (UpdateMethod m : kTryOrder)
    if (cheap(m) && slot(m).scans == 1) return m;
  const UpdateMethod fastest = best();
  UpdateMethod probe = fastest;
  std::uint64_t oldest = now + 1;
  for (UpdateMethod m : kTryOrder)
    if (m != fastest && slot(m).due <= now && slot(m).due < oldest && expectedExtraMs(m) <= budget_ms_)
      oldest = slot(m).due, probe = m;
  return probe;
}

double MethodChooser::expectedExtraMs(UpdateMethod m) const {
  const double best_us = slot(best()).us_per_point;
  const double extra_us =
      slot(m).scans == 0 ? options_.untried_extra * best_us : std::max(0.0, slot(m).us_per_point - best_us);
  return extra_us * points_per_scan_ / 1000.0;
}

void MethodChooser::record(UpdateMethod method, double ms, std::uint64_t points) {
  if (method == UpdateMethod::kFastest || points == 0) return;
  const UpdateMethod before = best();
  const bool probe = method != before;
  Slot& s = slot(method);
  const double us = 1000.0 * ms / static_cast<double>(points);
  // The budget: every scan earns its share of what the fastest would have taken; a try pays what it took
  // beyond that (nothing if it was faster).
  const Slot& b = slot(before);
  if (b.scans > 0) {
    const double fastest_ms = b.us_per_point * static_cast<double>(points) / 1000.0;
    budget_ms_ += options_.probe_budget * fastest_ms;
    if (probe) budget_ms_ -= std::max(0.0, ms - fastest_ms);
  }
  // The mean of the scans so far, then of about the last 50 (scans may grow or shrink).
  ++recorded_;
  points_per_scan_ +=
      (static_cast<double>(points) - points_per_scan_) * std::max(0.02, 1.0 / static_cast<double>(recorded_));
  // The first scans of a run are slow (buffers growing, caches cold): a method's first two times keep their
  // minimum, so a cold first try does not condemn it; later ones are smoothed.
  if (s.scans == 0)
    s.us_per_point = us;
  else if (s.scans == 1)
    s.us_per_point = std::min(s.us_per_point, us);
  else {
    // A loser's estimate is old when it is tried again (tens to hundreds of scans), so its new time
    // weighs more: the data may have changed since.
    const double w = probe ? options_.probe_weight : options_.smoothing;
    s.us_per_point = (1.0 - w) * s.us_per_point + w * us;
  }
  ++s.scans;
  const UpdateMethod after = best();
  // A loser waits longer each time it loses, up to max_interval scans: the method just measured when it
  // is not the fastest, and the one it displaced.
  const auto lose = [&](Slot& l) {
    l.due = scan_ + l.interval;
    l.interval = std::min(options_.max_interval, l.interval * 2);
  };
  if (method != after) lose(s);
  if (after != before && before != method && slot(before).scans > 0) lose(slot(before));
  if (method == after) s.interval = options_.probe_interval;
  if (after != before)
    spdlog::info("update method: {} is now the fastest ({:.3f} us per point; {})", toString(after),
                 slot(after).us_per_point, summary());
}

std::string MethodChooser::summary() const {
  std::vector<UpdateMethod> order(std::begin(kTryOrder), std::end(kTryOrder));
  std::stable_sort(order.begin(), order.end(),
                   [&](UpdateMethod a, UpdateMethod b) { return slot(a).scans > slot(b).scans; });
  std::string out;
  for (UpdateMethod m : order) {
    if (!out.empty()) out += ", ";
    out += std::string(toString(m)) + " " + std::to_string(slot(m).scans);
  }
  return out;
}

}  // namespace densemap::update
