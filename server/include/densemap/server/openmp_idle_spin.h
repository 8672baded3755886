// How long an idle OpenMP worker of this process spins before it sleeps. libgomp reads that once, from
// OMP_WAIT_POLICY and GOMP_SPINCOUNT, when it is loaded (before main), and by default a worker spins
// ~300,000 times after every parallel region: 21% of the server's CPU at 4 robots (docs/BENCHMARKS.md,
// the fleet section). So the server puts the setting in its environment and executes itself again, once.
#pragma once

#include <optional>
#include <string>

namespace densemap::server {

/// What to do for a configured spin count, given the environment's OMP_WAIT_POLICY and GOMP_SPINCOUNT
/// (nullptr: unset).
struct OpenmpIdleSpinPlan {
  /// Set GOMP_SPINCOUNT to this and execute again; empty when the environment already decides.
  std::optional<std::string> spin_count;
  /// One line for the log: what is in force and why.
  std::string message;
};

/// `configured` < 0 leaves libgomp's own default (or the environment) in force.
OpenmpIdleSpinPlan planOpenmpIdleSpin(int configured, const char* env_wait_policy,
                                      const char* env_spin_count);

/// Applies the plan for `configured` to this process: may replace it (execv of its own program file, same
/// arguments and pid) and then does not return. Call before any thread starts. When the re-execution
/// fails it logs why and returns, with libgomp's default in force.
void applyOpenmpIdleSpin(int configured, char** argv);

}  // namespace densemap::server
