// Which of the four exact update methods to run for the next scan. They give the same map
// (Ch. 2; tests/unit/test_exactness.cpp), so the choice changes only the time, and the time depends on the
// data: outdoors at 0.2 m a super ray carries ~1.04 points and costs more than it saves (Table 2.2 gives
// 1.6 points), while dense indoor scans, coarse voxels and densified scans group many points per ray.
// The engine asks it only about scans dense enough for super rays to save walking (min_saving_to_measure;
// other scans run the baseline). A scan's cost is known only after running it, so its choice is measured
// rather than predicted: the cheap methods (baseline, culling) are tried first, twice each (a run's first
// scan is a cold one), the super-ray ones no earlier than `probe_after` scans, each loser again after an
// interval that doubles every time it loses, and the method with the lowest smoothed time per point runs
// the other scans.
// Tries are paid from an exploration budget: every scan adds `probe_budget` of the fastest method's time,
// and a method other than the fastest runs only when the budget holds what it is expected to cost beyond
// the fastest (an untried super-ray method: `untried_extra` of the fastest's time). So trying costs at most
// about that share of the time however short or long the run, and a method that lost by much waits longer.
#pragma once

#include <array>
#include <cstdint>
#include <string>

#include "densemap/update/update_method.h"

namespace densemap::update {

struct MethodChooserOptions {
  /// The chooser is consulted only for scans whose previous scan could let super rays save at least this
  /// many walked cells per point (the walks of points whose endpoint cell another point already had, per
  /// point: UpdateStats::super_ray_saving, an upper bound on what grouping can save); other scans run the
  /// baseline without tries. Set from the data (docs/BENCHMARKS.md): on kitti00, hilti2023,
  /// la3dm and the simulator at 0.1-0.8 m this reached 65.5 (kitti00, 0.1 m), no method was faster than
  /// the baseline in all repetitions of any run, and super rays took 1.47x the baseline's time there
  /// (2026-12-05's method table); the threshold is twice that largest value. 0: always consult.
  double min_saving_to_measure = 130.0;
  std::uint64_t probe_after = 20;  ///< scans before the super-ray methods are first tried (at the earliest)
  std::uint64_t probe_interval = 20;  ///< scans between a losing method's tries, at least (doubles per loss)
  std::uint64_t max_interval = 640;   ///< the doubling stops here
  double probe_budget = 0.02;         ///< share of the fastest method's time that tries of others may cost
  double untried_extra = 0.5;         ///< an untried super-ray method's assumed extra time over the fastest
  double smoothing = 0.2;             ///< weight of the newest time in the running method's average
  double probe_weight = 0.5;          ///< the same for a method tried again after losing
};

class MethodChooser {
 public:
  explicit MethodChooser(MethodChooserOptions options = {}) : options_(options) {}

  /// The method for the next scan.
  UpdateMethod next();
  /// The time the scan took with `method` (generation + update) and its point count.
  void record(UpdateMethod method, double ms, std::uint64_t points);

  /// The method currently believed fastest (baseline before anything is measured).
  UpdateMethod best() const;
  /// Scans run with each method so far, and each one's smoothed microseconds per point (0: not tried).
  std::uint64_t scans(UpdateMethod m) const { return slot(m).scans; }
  double microsecondsPerPoint(UpdateMethod m) const { return slot(m).us_per_point; }
  /// "culling 37, baseline 2, superrays 1, superrays+culling 1" (most used first).
  std::string summary() const;
  /// The exploration budget not yet spent, in ms (negative: the tries so far cost more than it held).
  double budgetMs() const { return budget_ms_; }

 private:
  struct Slot {
    std::uint64_t scans = 0;
    double us_per_point = 0.0;
    std::uint64_t due = 0;  ///< scan number of its next try
    std::uint64_t interval = 0;
  };
  Slot& slot(UpdateMethod m) { return slots_[static_cast<std::size_t>(m)]; }
  const Slot& slot(UpdateMethod m) const { return slots_[static_cast<std::size_t>(m)]; }

  MethodChooserOptions options_;
  std::array<Slot, 4> slots_{};
  /// What a try of `m` is expected to cost beyond a scan of the fastest method (ms).
  double expectedExtraMs(UpdateMethod m) const;

  std::uint64_t scan_ = 0;
  bool started_ = false;
  double budget_ms_ = 0.0;        ///< exploration budget not yet spent (negative: overspent)
  double points_per_scan_ = 0.0;  ///< recent mean, to turn times per point into times per scan
  std::uint64_t recorded_ = 0;
};

}  // namespace densemap::update
