#include "densemap/server/openmp_idle_spin.h"

#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>

#include <spdlog/spdlog.h>

namespace densemap::server {

OpenmpIdleSpinPlan planOpenmpIdleSpin(int configured, const char* env_wait_policy,
                                      const char* env_spin_count) {
  OpenmpIdleSpinPlan plan;
  const std::string wanted = std::to_string(configured);
  if (env_spin_count != nullptr) {
    // Our own re-execution lands here too (the value matches), as does a user's explicit choice.
    plan.message = std::string("idle OpenMP workers spin GOMP_SPINCOUNT=") + env_spin_count +
                   " times before they sleep" +
                   (configured >= 0 && wanted != env_spin_count
                        ? " (the environment's GOMP_SPINCOUNT wins over --update-idle-spin " + wanted + ")"
                        : "");
    return plan;
  }
  if (env_wait_policy != nullptr) {
    plan.message =
        std::string("idle OpenMP workers follow OMP_WAIT_POLICY=") + env_wait_policy +
        (configured >= 0 ? " from the environment (it wins over --update-idle-spin " + wanted + ")" : "");
    return plan;
  }
  if (configured < 0) {
    plan.message = "idle OpenMP workers spin as libgomp's default says (--update-idle-spin -1)";
    return plan;
  }
  plan.spin_count = wanted;
  plan.message = "idle OpenMP workers spin " + wanted + " times before they sleep (--update-idle-spin)";
  return plan;
}

void applyOpenmpIdleSpin(int configured, char** argv) {
  const OpenmpIdleSpinPlan plan =
      planOpenmpIdleSpin(configured, std::getenv("OMP_WAIT_POLICY"), std::getenv("GOMP_SPINCOUNT"));
  if (!plan.spin_count) {
    spdlog::info("{}", plan.message);
    return;
  }
  if (setenv("GOMP_SPINCOUNT", plan.spin_count->c_str(), 1) != 0) {
    spdlog::warn("cannot set GOMP_SPINCOUNT ({}): idle OpenMP workers spin as libgomp's default says",
                 std::strerror(errno));
    return;
  }
  // Same pid and arguments; nothing has started yet, so nothing is lost. The program's own path rather than
  // /proc/self/exe, so the process keeps its name (ps, pgrep, top show the file's name).
  std::string self(4096, '\0');
  const ssize_t n = readlink("/proc/self/exe", self.data(), self.size() - 1);
  self.resize(n > 0 ? static_cast<std::size_t>(n) : 0);
  if (self.empty() || self.ends_with(" (deleted)")) self = "/proc/self/exe";  // replaced on disk since
  execv(self.c_str(), argv);
  spdlog::warn(
      "cannot execute {} again to apply --update-idle-spin ({}); idle OpenMP workers spin as "
      "libgomp's default says. Set GOMP_SPINCOUNT={} in the server's environment instead.",
      self, std::strerror(errno), *plan.spin_count);
  unsetenv("GOMP_SPINCOUNT");
}

}  // namespace densemap::server
