// Running one of our programs through the shell, as a user does, for tests of its exit status and output.
#pragma once

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <string>

namespace densemap::test {

struct CommandResult {
  int wait_status = -1;  ///< as waitpid gives it (-1: could not start)
  std::string output;    ///< standard output (and standard error when captured)
  /// The exit code, or -1 when the program did not exit normally (a signal, or it could not start).
  int exitCode() const { return wait_status >= 0 && WIFEXITED(wait_status) ? WEXITSTATUS(wait_status) : -1; }
  bool signalled() const { return wait_status >= 0 && WIFSIGNALED(wait_status); }
};

enum class Stderr { kCapture, kDrop };

inline CommandResult runCommand(const std::string& command, Stderr err = Stderr::kDrop) {
  CommandResult r;
  FILE* pipe = popen((command + (err == Stderr::kCapture ? " 2>&1" : " 2>/dev/null")).c_str(), "r");
  if (pipe == nullptr) return r;
  std::array<char, 4096> buf;
  while (std::fgets(buf.data(), buf.size(), pipe) != nullptr) r.output += buf.data();
  r.wait_status = pclose(pipe);
  return r;
}

}  // namespace densemap::test
