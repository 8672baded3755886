// Decay: in a world where things move, a cell that no scan observes again should not keep its
// old belief forever. Every known cell relaxes toward unknown (log-odds 0) at a constant rate, in steps of
// map time; observations pull it back as before. Off by default: the OctoMap-equal maps stay the default.
#pragma once

#include <cmath>
#include <limits>
#include <string>

namespace densemap::map {

struct DecayOptions {
  /// Seconds without observations for a cell at the upper clamp to become unknown; 0 turns decay off. The
  /// rate is the upper clamp's log-odds over this time (a free cell at the lower clamp, nearer 0, gets
  /// there sooner).
  double seconds_to_unknown = 0.0;
  /// Decay is applied in steps of this much map time, to every block at once, so between steps the map is
  /// fixed and a scan's culling region sees one consistent map.
  double step_s = 1.0;

  bool enabled() const { return seconds_to_unknown > 0.0; }
  /// Empty when valid, else what is wrong.
  std::string validate() const {
    if (!(seconds_to_unknown >= 0.0) || !std::isfinite(seconds_to_unknown))
      return "decay time must be a finite number of seconds >= 0";
    if (!(step_s > 0.0) || !std::isfinite(step_s)) return "decay step must be a finite number of seconds > 0";
    return {};
  }
};

/// A value after `amount` log-odds of relaxation toward 0: unknown (NaN) once it would reach 0 or cross it.
inline float relaxedTowardUnknown(float value, float amount) {
  if (std::isnan(value)) return value;
  if (std::fabs(value) <= amount) return std::numeric_limits<float>::quiet_NaN();
  return value > 0.0f ? value - amount : value + amount;
}

}  // namespace densemap::map
